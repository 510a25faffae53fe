// Test helper (header-only, libexif): a JPEG with an Exif APP1 segment carrying the fields freeloc reads, written the
// way a camera writes them — for the EXIF reader's tests, the CLI's intrinsics tests and the fuzz corpus.
#pragma once

#include <libexif/exif-data.h>

#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

namespace freeloc::testing {

struct ExifFields {
  int orientation = 0;              // 0: no tag
  ExifRational focal_length{0, 0};  // {0, 0}: no tag
  int focal_35mm = -1;              // -1: no tag
  ExifRational focal_plane_x{0, 0}, focal_plane_y{0, 0};
  int focal_plane_unit = 0;      // 0: no tag
  int pixel_x = 0, pixel_y = 0;  // 0: no tag
  ExifByteOrder order = EXIF_BYTE_ORDER_INTEL;
};

inline ExifRational Rational(double v, uint32_t denominator = 10000) {
  return {static_cast<uint32_t>(v * denominator + 0.5), denominator};
}

namespace exif_writer_internal {

inline void Add(ExifData* d, ExifIfd ifd, ExifTag tag, ExifFormat format, ExifMem* mem, const void* value,
                ExifByteOrder order) {
  ExifEntry* e = exif_entry_new_mem(mem);
  e->tag = tag;
  e->format = format;
  e->components = 1;
  e->size = exif_format_get_size(format);
  e->data = static_cast<unsigned char*>(exif_mem_alloc(mem, e->size));
  if (format == EXIF_FORMAT_SHORT) exif_set_short(e->data, order, *static_cast<const uint16_t*>(value));
  if (format == EXIF_FORMAT_LONG) exif_set_long(e->data, order, *static_cast<const uint32_t*>(value));
  if (format == EXIF_FORMAT_RATIONAL) exif_set_rational(e->data, order, *static_cast<const ExifRational*>(value));
  exif_content_add_entry(d->ifd[ifd], e);
  exif_entry_unref(e);
}

}  // namespace exif_writer_internal

// The APP1 payload ("Exif\0\0" + TIFF) for `f`.
inline std::vector<uint8_t> ExifPayload(const ExifFields& f) {
  using exif_writer_internal::Add;
  ExifMem* mem = exif_mem_new_default();
  ExifData* d = exif_data_new_mem(mem);
  exif_data_unset_option(d, EXIF_DATA_OPTION_FOLLOW_SPECIFICATION);
  exif_data_set_byte_order(d, f.order);
  if (f.orientation) {
    const uint16_t v = static_cast<uint16_t>(f.orientation);
    Add(d, EXIF_IFD_0, EXIF_TAG_ORIENTATION, EXIF_FORMAT_SHORT, mem, &v, f.order);
  }
  if (f.focal_length.denominator || f.focal_length.numerator)
    Add(d, EXIF_IFD_EXIF, EXIF_TAG_FOCAL_LENGTH, EXIF_FORMAT_RATIONAL, mem, &f.focal_length, f.order);
  if (f.focal_35mm >= 0) {
    const uint16_t v = static_cast<uint16_t>(f.focal_35mm);
    Add(d, EXIF_IFD_EXIF, EXIF_TAG_FOCAL_LENGTH_IN_35MM_FILM, EXIF_FORMAT_SHORT, mem, &v, f.order);
  }
  if (f.focal_plane_x.denominator || f.focal_plane_x.numerator)
    Add(d, EXIF_IFD_EXIF, EXIF_TAG_FOCAL_PLANE_X_RESOLUTION, EXIF_FORMAT_RATIONAL, mem, &f.focal_plane_x, f.order);
  if (f.focal_plane_y.denominator || f.focal_plane_y.numerator)
    Add(d, EXIF_IFD_EXIF, EXIF_TAG_FOCAL_PLANE_Y_RESOLUTION, EXIF_FORMAT_RATIONAL, mem, &f.focal_plane_y, f.order);
  if (f.focal_plane_unit) {
    const uint16_t v = static_cast<uint16_t>(f.focal_plane_unit);
    Add(d, EXIF_IFD_EXIF, EXIF_TAG_FOCAL_PLANE_RESOLUTION_UNIT, EXIF_FORMAT_SHORT, mem, &v, f.order);
  }
  if (f.pixel_x) {
    const uint32_t v = static_cast<uint32_t>(f.pixel_x);
    Add(d, EXIF_IFD_EXIF, EXIF_TAG_PIXEL_X_DIMENSION, EXIF_FORMAT_LONG, mem, &v, f.order);
  }
  if (f.pixel_y) {
    const uint32_t v = static_cast<uint32_t>(f.pixel_y);
    Add(d, EXIF_IFD_EXIF, EXIF_TAG_PIXEL_Y_DIMENSION, EXIF_FORMAT_LONG, mem, &v, f.order);
  }
  unsigned char* buf = nullptr;
  unsigned int len = 0;
  exif_data_save_data(d, &buf, &len);
  exif_data_unref(d);
  if (!buf) {
    exif_mem_unref(mem);
    throw std::runtime_error("ExifPayload: libexif wrote nothing");
  }
  std::vector<uint8_t> out(buf, buf + len);
  exif_mem_free(mem, buf);
  exif_mem_unref(mem);
  return out;
}

// `jpeg` with an APP1 segment holding `payload` right after its SOI marker.
inline std::vector<uint8_t> WithApp1(const std::vector<uint8_t>& jpeg, const std::vector<uint8_t>& payload) {
  if (jpeg.size() < 2 || jpeg[0] != 0xFF || jpeg[1] != 0xD8) throw std::runtime_error("WithApp1: not a JPEG");
  const size_t len = payload.size() + 2;
  if (len > 0xFFFF) throw std::runtime_error("WithApp1: payload too large for one segment");
  std::vector<uint8_t> out = {0xFF, 0xD8, 0xFF, 0xE1, static_cast<uint8_t>(len >> 8), static_cast<uint8_t>(len)};
  out.insert(out.end(), payload.begin(), payload.end());
  out.insert(out.end(), jpeg.begin() + 2, jpeg.end());
  return out;
}

inline std::vector<uint8_t> WithExif(const std::vector<uint8_t>& jpeg, const ExifFields& f) {
  return WithApp1(jpeg, ExifPayload(f));
}

}  // namespace freeloc::testing
