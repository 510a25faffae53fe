// Grey and RGB PNG through libpng directly (lossless both ways, so the values equal any other decoder's): depth maps,
// masks and written images need no OpenCV image codecs, which load ~140 libraries (io/internal/codecs_api.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace freeloc::io::internal {

// A single-channel PNG of 1–16 bits; 1/2/4-bit grey is scaled to 8 bits as OpenCV's IMREAD_UNCHANGED does. Values
// row-major; `bits` 8 or 16. Throws freeloc::Error naming `what` (not grey, damaged).
std::vector<uint16_t> DecodeGreyPng(const std::vector<uint8_t>& bytes, const std::string& what, int* width, int* height,
                                    int* bits);

// Encodes `channels` (1 grey, 3 RGB) × `bits` (8 or 16) samples, row-major; default compression.
std::vector<uint8_t> EncodePng(const void* data, int width, int height, int channels, int bits,
                               const std::string& what);

}  // namespace freeloc::io::internal
