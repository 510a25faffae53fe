#include "freeloc/io/internal/png.h"

#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <cstring>

#include "freeloc/core/error.h"
#include "freeloc/core/limits.h"

namespace freeloc::io::internal {

namespace {

// libpng reports errors by longjmp to the setjmp of the calling function; the message is kept here. No C++ object
// with a destructor is created between a setjmp and the libpng calls it guards (only the caller's objects, which
// outlive the jump).
struct PngError {
  char message[256] = "";
};

void OnError(png_structp png, png_const_charp msg) {
  auto* e = static_cast<PngError*>(png_get_error_ptr(png));
  std::snprintf(e->message, sizeof(e->message), "%s", msg ? msg : "libpng error");
  png_longjmp(png, 1);
}
void OnWarning(png_structp, png_const_charp) {}

struct Reader {
  const uint8_t* data;
  size_t size, pos;
};
void ReadFn(png_structp png, png_bytep out, png_size_t n) {
  auto* r = static_cast<Reader*>(png_get_io_ptr(png));
  if (n > r->size - r->pos) png_error(png, "unexpected end of data");
  std::memcpy(out, r->data + r->pos, n);
  r->pos += n;
}

void WriteFn(png_structp png, png_bytep in, png_size_t n) {
  auto* v = static_cast<std::vector<uint8_t>*>(png_get_io_ptr(png));
  v->insert(v->end(), in, in + n);
}
void FlushFn(png_structp) {}

// Returns false with `err` set on failure; `out` sized by the caller's vector (outlives any jump).
bool Decode(const std::vector<uint8_t>& bytes, std::vector<uint16_t>* out, std::vector<png_bytep>* rows, int* width,
            int* height, int* bits, int* channels, PngError* err) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, err, OnError, OnWarning);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  Reader reader{bytes.data(), bytes.size(), 0};
  if (!info || setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
    return false;
  }
  png_set_read_fn(png, &reader, ReadFn);
  png_read_info(png, info);
  const png_uint_32 w = png_get_image_width(png, info), h = png_get_image_height(png, info);
  if (static_cast<uint64_t>(w) * h > static_cast<uint64_t>(Limits().max_image_pixels))
    png_error(png, "more pixels than max_image_pixels allows");
  const int depth = png_get_bit_depth(png, info);
  const int type = png_get_color_type(png, info);
  *channels = png_get_channels(png, info);
  if (type != PNG_COLOR_TYPE_GRAY) {
    if (type == PNG_COLOR_TYPE_PALETTE) *channels = 3;
    png_destroy_read_struct(&png, &info, nullptr);
    return true;  // the caller reports the channel count
  }
  if (depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (depth == 16) png_set_swap(png);  // PNG is big-endian
  png_read_update_info(png, info);
  *width = static_cast<int>(w);
  *height = static_cast<int>(h);
  *bits = depth == 16 ? 16 : 8;
  const size_t row_bytes = png_get_rowbytes(png, info);
  // 16-bit rows are read in place; 8-bit rows into the upper half of each row's 16-bit slots, then widened.
  out->resize(static_cast<size_t>(w) * h);
  rows->resize(h);
  for (png_uint_32 y = 0; y < h; ++y)
    (*rows)[y] = reinterpret_cast<png_bytep>(out->data() + static_cast<size_t>(y) * w);
  if (row_bytes > static_cast<size_t>(w) * 2) png_error(png, "unexpected row size");
  png_read_image(png, rows->data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

}  // namespace

std::vector<uint16_t> DecodeGreyPng(const std::vector<uint8_t>& bytes, const std::string& what, int* width, int* height,
                                    int* bits) {
  std::vector<uint16_t> out;
  std::vector<png_bytep> rows;
  PngError err;
  int w = 0, h = 0, b = 0, channels = 1;
  FREELOC_CHECK(Decode(bytes, &out, &rows, &w, &h, &b, &channels, &err),
                what << ": cannot decode the PNG (" << err.message << "); the file is damaged");
  FREELOC_CHECK(channels == 1, what << ": expected a single-channel PNG, got " << channels << " channels");
  if (b == 8) {
    // Row y's 8-bit samples sit at the start of its 16-bit slots; widen from the end backwards.
    for (int y = 0; y < h; ++y) {
      uint16_t* row = out.data() + static_cast<size_t>(y) * w;
      const uint8_t* src = reinterpret_cast<const uint8_t*>(row);
      for (int x = w - 1; x >= 0; --x) row[x] = src[x];
    }
  }
  *width = w;
  *height = h;
  if (bits) *bits = b;
  return out;
}

namespace {
bool Encode(const void* data, int width, int height, int channels, int bits, std::vector<uint8_t>* out,
            std::vector<png_bytep>* rows, PngError* err) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, err, OnError, OnWarning);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, info ? &info : nullptr);
    return false;
  }
  png_set_write_fn(png, out, WriteFn, FlushFn);
  png_set_IHDR(png, info, width, height, bits, channels == 1 ? PNG_COLOR_TYPE_GRAY : PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (bits == 16) png_set_swap(png);
  const size_t row_bytes = static_cast<size_t>(width) * channels * (bits / 8);
  for (int y = 0; y < height; ++y)
    (*rows)[y] = const_cast<png_bytep>(static_cast<const uint8_t*>(data) + static_cast<size_t>(y) * row_bytes);
  png_write_image(png, rows->data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}
}  // namespace

std::vector<uint8_t> EncodePng(const void* data, int width, int height, int channels, int bits,
                               const std::string& what) {
  FREELOC_CHECK(width > 0 && height > 0 && (channels == 1 || channels == 3) && (bits == 8 || bits == 16),
                what << ": cannot encode a " << width << "x" << height << "x" << channels << " " << bits << "-bit PNG");
  std::vector<uint8_t> out;
  std::vector<png_bytep> rows(static_cast<size_t>(height));
  PngError err;
  FREELOC_CHECK(Encode(data, width, height, channels, bits, &out, &rows, &err),
                what << ": PNG encoding failed (" << err.message << ")");
  return out;
}

}  // namespace freeloc::io::internal
