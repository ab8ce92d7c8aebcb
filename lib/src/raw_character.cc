#include "skinspheres/lib/raw_character.h"
