// The one translation unit that compiles tinygltf's implementation (header at
// /usr/include/tiny_gltf.h). No images are decoded or written: the engine
// reads only geometry, and stb_image_write's implementation already lives in
// engine/scene/png_write.cpp. Every file that includes tiny_gltf.h must define
// the same three TINYGLTF_NO_* macros first, so TinyGLTF's inline members agree.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
#pragma GCC diagnostic ignored "-Wcast-align"
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wunused-variable"
#pragma GCC diagnostic ignored "-Wsign-compare"
#include <tiny_gltf.h>
#pragma GCC diagnostic pop
