// The run-time version query (skinspheres/version.h): the version this library was built as.
#include "skinspheres/version.h"

namespace skinspheres {

int LibraryVersion() { return SKINSPHERES_VERSION; }
const char* LibraryVersionString() { return SKINSPHERES_VERSION_STRING; }

}  // namespace skinspheres
