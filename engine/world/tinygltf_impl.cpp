// The one translation unit that compiles tinygltf's implementation; every
// other file includes world/tinygltf_include.h (same configuration macros).
#define TINYGLTF_IMPLEMENTATION
#include "world/tinygltf_include.h"
