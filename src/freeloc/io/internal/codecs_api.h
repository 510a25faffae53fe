// The image codecs module (libfreeloc_codecs.so): OpenCV's imgcodecs behind a table of functions, loaded on first use
// (core/module_loader.h) because imgcodecs pulls in ~140 shared libraries (GDAL, …) — 50 MB and 60 ms at start-up
// for every command, images or not. Internal to io.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "freeloc/core/image.h"

namespace freeloc::io::internal {

struct CodecsApi {
  int abi;  // kCodecsAbi of the build that made the module
  // Any format OpenCV decodes, to RGB8 as stored (the EXIF orientation is not applied: io does that). False + message
  // on failure.
  bool (*decode_rgb)(const uint8_t* bytes, size_t size, Image* out, std::string* error);
  // Baseline JPEG of an RGB8 image at `quality` (0–100).
  bool (*encode_jpeg)(const Image& rgb, int quality, std::vector<uint8_t>* out, std::string* error);
  // As decode_rgb, a JPEG decoded at 1/`reduce` of its size (2, 4, 8: libjpeg's scaled IDCT; 1: full size).
  bool (*decode_rgb_reduced)(const uint8_t* bytes, size_t size, int reduce, Image* out, std::string* error);
  // An area-averaging resize of an RGB8 image to width × height (OpenCV's INTER_AREA).
  bool (*resize_area)(const Image& in, int width, int height, Image* out, std::string* error);
};
constexpr int kCodecsAbi = 3;  // 3: decoders leave the EXIF orientation to io
constexpr const char* kCodecsLibrary = "libfreeloc_codecs.so";
constexpr const char* kCodecsEntry = "freeloc_codecs_v1";

// The module's table (loaded on first call; throws freeloc::Error when it cannot be).
const CodecsApi& Codecs();

}  // namespace freeloc::io::internal
