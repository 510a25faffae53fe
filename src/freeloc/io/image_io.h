// Image decoding (OpenCV's imgcodecs, loaded on first use: io/internal/codecs_api.h) honouring the EXIF orientation, as
// Pillow's ImageOps.exif_transpose does. The format is detected from the content, not the extension; truncated files
// are refused.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "freeloc/core/image.h"
#include "freeloc/io/exif.h"

namespace freeloc::io {

enum class ImageFormat { kUnknown, kJpeg, kPng, kBmp, kTiff, kWebp };
ImageFormat SniffImageFormat(const uint8_t* bytes, size_t size);
const char* ImageFormatName(ImageFormat f);
// The stored width and height an image's header declares (JPEG, PNG, …), without decoding; false when it cannot tell.
bool ImageHeaderSize(const std::vector<uint8_t>& bytes, uint64_t* width, uint64_t* height);

// Decodes to RGB8 (grey is replicated, alpha dropped). Throws freeloc::Error naming `what` when the bytes are not
// a supported image, are truncated or cannot be decoded.
Image DecodeImage(const std::vector<uint8_t>& bytes, const std::string& what);
Image ReadImage(const std::string& path);
// The same, with the file's EXIF (exif.h) in `exif`: its orientation is the one the decoder applied, and intrinsics
// from it describe the image as returned (displayed orientation).
Image ReadImage(const std::string& path, ExifInfo* exif);

// A working resolution (PipelineOptions inputs.max_side): with `max_side` > 0 a photo whose long side is larger is
// decoded at that size — JPEG's scaled decoding (1/2, 1/4, 1/8) where it reaches, then an area resize — never
// holding the full-resolution pixels of a JPEG it can scale; the photo's own displayed size stays in
// Image::photo_width/photo_height, which intrinsics, depth maps and correspondences refer to.
Image DecodeImage(const std::vector<uint8_t>& bytes, const std::string& what, int max_side);
Image ReadImage(const std::string& path, ExifInfo* exif, int max_side);
// The working size of a width × height photo: its long side at most `max_side` (0: no limit), the aspect kept.
void WorkingSize(int width, int height, int max_side, int* w, int* h);
// An area-averaging reduction of `image` to width × height (each at most the image's), keeping its photo size.
Image ShrinkImage(const Image& image, int width, int height);

// Lossless PNG, written atomically.
void WriteImagePng(const std::string& path, const Image& image);

// Single-channel 8-bit PNG (masks: 0/255), written atomically.
void WritePng8(const std::string& path, int width, int height, const std::vector<uint8_t>& values);

// Single-channel 16-bit PNG (e.g. depth in millimetres); values row-major. Written atomically.
void WritePng16(const std::string& path, int width, int height, const std::vector<uint16_t>& values);
// Reads a single-channel 8- or 16-bit PNG without any conversion; `bits` (optional) receives 8 or 16.
std::vector<uint16_t> ReadPng16(const std::string& path, int* width, int* height, int* bits = nullptr);
// The same from the file's bytes (an upload); `what` names it in errors.
std::vector<uint16_t> DecodePng16(const std::vector<uint8_t>& bytes, const std::string& what, int* width, int* height,
                                  int* bits = nullptr);

// Baseline JPEG of an RGB8 image at `quality` (0-100); `what` names it in errors.
std::vector<uint8_t> EncodeJpeg(const Image& rgb, int quality, const std::string& what);

}  // namespace freeloc::io
