// tinygltf and stb_image compiled into the fuzz target with its sanitizers and
// coverage instrumentation, in place of Debian's libtinygltf.so and libstb.so
// (the same sources: /usr/include/tiny_gltf.h 2.7, /usr/include/stb).
#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_INCLUDE_STB_IMAGE
#define TINYGLTF_NO_INCLUDE_STB_IMAGE_WRITE
#include <tiny_gltf.h>
