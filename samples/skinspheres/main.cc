// skinspheres: the command-line tool (fit, demo, play, export-builtin).
#include <cstdio>

int main() {
  std::puts("skinspheres: nothing here yet");
  return 0;
}
