#include "freeloc/io/exif.h"

#include <libexif/exif-data.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <sstream>

namespace freeloc::io {

namespace {

// The payload of the first APP1 segment that starts with "Exif\0\0" (header included, as libexif expects), found by
// walking the marker segments from SOI up to the first scan. nullptr when there is none or the walk leaves the file.
const uint8_t* FindExifSegment(const uint8_t* b, size_t n, size_t* len) {
  if (n < 4 || b[0] != 0xFF || b[1] != 0xD8) return nullptr;
  size_t k = 2;
  while (k + 4 <= n) {
    if (b[k] != 0xFF) return nullptr;
    const uint8_t m = b[k + 1];
    if (m == 0xFF) {  // fill byte
      ++k;
      continue;
    }
    if (m == 0xD8 || m == 0x01 || (m >= 0xD0 && m <= 0xD7)) {  // standalone markers
      k += 2;
      continue;
    }
    if (m == 0xDA || m == 0xD9) return nullptr;             // the scan (or the end): EXIF comes before it
    const size_t seg = (size_t{b[k + 2]} << 8) | b[k + 3];  // includes its own two length bytes
    if (seg < 2 || seg > n - k - 2) return nullptr;
    if (m == 0xE1 && seg >= 2 + 6 && std::memcmp(b + k + 4, "Exif\0\0", 6) == 0) {
      *len = seg - 2;
      return b + k + 4;
    }
    k += 2 + seg;
  }
  return nullptr;
}

struct ExifDataFree {
  void operator()(ExifData* d) const { exif_data_unref(d); }
};

class Reader {
 public:
  Reader(ExifData* d, ExifInfo* info) : d_(d), order_(exif_data_get_byte_order(d)), info_(info) {}

  const ExifEntry* Entry(ExifIfd ifd, ExifTag tag) const {
    return d_->ifd[ifd] ? exif_content_get_entry(d_->ifd[ifd], tag) : nullptr;
  }

  // One SHORT (or LONG) value; false when absent or of another shape (said in problems when present).
  bool Integer(ExifIfd ifd, ExifTag tag, const char* name, long* out) const {
    const ExifEntry* e = Entry(ifd, tag);
    if (!e) return false;
    if (e->components >= 1 && e->data) {
      if (e->format == EXIF_FORMAT_SHORT && e->size >= 2) {
        *out = exif_get_short(e->data, order_);
        return true;
      }
      if (e->format == EXIF_FORMAT_LONG && e->size >= 4) {
        *out = static_cast<long>(exif_get_long(e->data, order_));
        return true;
      }
    }
    Problem(name, "is not an integer");
    return false;
  }

  // One RATIONAL value > 0 and finite; false when absent or unusable (said in problems when present).
  bool Positive(ExifIfd ifd, ExifTag tag, const char* name, double* out) const {
    const ExifEntry* e = Entry(ifd, tag);
    if (!e) return false;
    if (e->format != EXIF_FORMAT_RATIONAL || e->components < 1 || !e->data || e->size < 8) {
      Problem(name, "is not a rational number");
      return false;
    }
    const ExifRational r = exif_get_rational(e->data, order_);
    if (r.denominator == 0 || r.numerator == 0) {
      Problem(name, r.denominator == 0 ? "has a zero denominator" : "is zero");
      return false;
    }
    *out = static_cast<double>(r.numerator) / r.denominator;
    return true;
  }

  std::string Ascii(ExifIfd ifd, ExifTag tag) const {
    const ExifEntry* e = Entry(ifd, tag);
    if (!e || e->format != EXIF_FORMAT_ASCII || !e->data) return "";
    std::string s(reinterpret_cast<const char*>(e->data), std::min<size_t>(e->size, 64));
    s = s.substr(0, s.find('\0'));
    for (char& c : s)
      if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7E) c = '?';
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s;
  }

  void Problem(const char* name, const std::string& what) const {
    info_->problems.push_back(std::string(name) + " " + what);
  }

 private:
  ExifData* d_;
  ExifByteOrder order_;
  ExifInfo* info_;
};

}  // namespace

ExifInfo ReadExif(const uint8_t* bytes, size_t size) {
  ExifInfo info;
  size_t len = 0;
  const uint8_t* seg = bytes ? FindExifSegment(bytes, size, &len) : nullptr;
  if (!seg) return info;
  std::unique_ptr<ExifData, ExifDataFree> d(exif_data_new());
  if (!d) return info;
  // Read what is there: following the specification would add default values for missing mandatory tags.
  exif_data_unset_option(d.get(), EXIF_DATA_OPTION_FOLLOW_SPECIFICATION);
  exif_data_load_data(d.get(), seg, static_cast<unsigned int>(len));
  info.present = true;
  const Reader r(d.get(), &info);

  long v = 0;
  if (r.Integer(EXIF_IFD_0, EXIF_TAG_ORIENTATION, "Orientation", &v)) {
    if (v >= 1 && v <= 8)
      info.orientation = static_cast<int>(v);
    else
      r.Problem("Orientation", std::to_string(v) + " is not 1-8");
  }
  double x = 0;
  if (r.Positive(EXIF_IFD_EXIF, EXIF_TAG_FOCAL_LENGTH, "FocalLength", &x)) info.focal_length_mm = x;
  if (r.Integer(EXIF_IFD_EXIF, EXIF_TAG_FOCAL_LENGTH_IN_35MM_FILM, "FocalLengthIn35mmFilm", &v) && v > 0)
    info.focal_length_35mm = static_cast<int>(v);
  if (r.Positive(EXIF_IFD_EXIF, EXIF_TAG_FOCAL_PLANE_X_RESOLUTION, "FocalPlaneXResolution", &x))
    info.focal_plane_x_resolution = x;
  if (r.Positive(EXIF_IFD_EXIF, EXIF_TAG_FOCAL_PLANE_Y_RESOLUTION, "FocalPlaneYResolution", &x))
    info.focal_plane_y_resolution = x;
  if (r.Integer(EXIF_IFD_EXIF, EXIF_TAG_FOCAL_PLANE_RESOLUTION_UNIT, "FocalPlaneResolutionUnit", &v)) {
    if (v >= 2 && v <= 5) {
      info.focal_plane_unit = static_cast<int>(v);
    } else {  // 1 ("no absolute unit") or anything else: the resolution is in no known length, so unusable
      info.focal_plane_unit = -1;
      r.Problem("FocalPlaneResolutionUnit", std::to_string(v) + " is not 2 (inch), 3 (cm), 4 (mm) or 5 (um)");
    }
  }
  if (r.Integer(EXIF_IFD_EXIF, EXIF_TAG_PIXEL_X_DIMENSION, "PixelXDimension", &v) && v > 0 && v < (1 << 20))
    info.pixel_x_dimension = static_cast<int>(v);
  if (r.Integer(EXIF_IFD_EXIF, EXIF_TAG_PIXEL_Y_DIMENSION, "PixelYDimension", &v) && v > 0 && v < (1 << 20))
    info.pixel_y_dimension = static_cast<int>(v);
  info.make = r.Ascii(EXIF_IFD_0, EXIF_TAG_MAKE);
  info.model = r.Ascii(EXIF_IFD_0, EXIF_TAG_MODEL);
  return info;
}

std::string OrientationText(int o) {
  switch (o) {
    case 1: return "upright";
    case 2: return "mirrored left-right";
    case 3: return "rotated 180°";
    case 4: return "mirrored top-bottom";
    case 5: return "transposed (mirrored and rotated 90°)";
    case 6: return "rotated 90° clockwise";
    case 7: return "transversed (mirrored and rotated 270°)";
    case 8: return "rotated 90° counter-clockwise";
    default: return "no orientation tag";
  }
}

bool CameraFromExif(const ExifInfo& e, int width, int height, Camera* camera, std::string* why, std::string* refused) {
  std::ostringstream reasons;
  if (!e.present) {
    if (why) *why = "no EXIF";
    return false;
  }
  if (width <= 0 || height <= 0) {
    if (why) *why = "no image size";
    return false;
  }
  const double long_side = std::max(width, height);
  const auto plausible = [&](double f) { return std::isfinite(f) && f >= 0.1 * long_side && f <= 20 * long_side; };
  // The stored image's size (the one the tags describe): displayed width/height swap back for orientations 5–8.
  const int stored_w = e.transposed() ? height : width, stored_h = e.transposed() ? width : height;
  Camera k;
  k.width = width;
  k.height = height;
  k.cx = (width - 1) / 2.0;
  k.cy = (height - 1) / 2.0;

  if (e.focal_length_mm > 0 && e.focal_plane_x_resolution > 0 && e.focal_plane_unit < 0)
    reasons << "FocalPlaneResolution in no known length unit (FocalPlaneResolutionUnit is not inch, cm, mm or um); ";
  if (e.focal_length_mm > 0 && e.focal_plane_x_resolution > 0 && e.focal_plane_unit >= 0) {
    // Pixels per millimetre on the sensor: FocalPlaneResolutionUnit 2 inch (the EXIF default), 3 cm, 4 mm, 5 µm.
    const int unit = e.focal_plane_unit ? e.focal_plane_unit : 2;
    const double mm_per_unit = unit == 2 ? 25.4 : unit == 3 ? 10.0 : unit == 4 ? 1.0 : 1e-3;
    const double yres = e.focal_plane_y_resolution > 0 ? e.focal_plane_y_resolution : e.focal_plane_x_resolution;
    // Tags written for the camera's image: a file resized afterwards scales them. PixelX/YDimension say the size
    // they were written for — of the stored image by the standard; written for the displayed one by some tools (told
    // apart by the aspect ratio); of another aspect ratio (a crop, which changes no focal) they are not used.
    double sx = 1, sy = 1;
    const auto same_aspect = [](double w1, double h1, double w2, double h2) {
      return std::abs(w1 * h2 - w2 * h1) <= 0.01 * w1 * h2;
    };
    const double px = e.pixel_x_dimension, py = e.pixel_y_dimension;
    if (px > 0 && py > 0) {
      if (same_aspect(px, py, stored_w, stored_h)) {
        sx = stored_w / px;
        sy = stored_h / py;
      } else if (e.transposed() && same_aspect(px, py, width, height)) {
        sx = stored_w / py;
        sy = stored_h / px;
      }
    } else if (px > 0) {
      sx = sy = stored_w / px;
    }
    const double fx_stored = e.focal_length_mm * e.focal_plane_x_resolution / mm_per_unit * sx;
    const double fy_stored = e.focal_length_mm * yres / mm_per_unit * sy;
    k.fx = e.transposed() ? fy_stored : fx_stored;
    k.fy = e.transposed() ? fx_stored : fy_stored;
    if (plausible(k.fx) && plausible(k.fy) && std::max(k.fx, k.fy) <= 1.5 * std::min(k.fx, k.fy)) {
      *camera = k;
      if (why) *why = "FocalLength × FocalPlaneResolution";
      return true;
    }
    reasons << "FocalLength " << e.focal_length_mm << " mm × FocalPlaneResolution gives fx " << k.fx << ", fy " << k.fy
            << " px: absurd for a " << width << "x" << height << " image; ";
  }
  if (e.focal_length_35mm > 0) {
    // The 35 mm frame is 36 × 24 mm; its 36 mm side is taken across the image's long side. (Some makers scale by the
    // diagonal, 43.3 mm: identical for 3:2 images, 4 % apart for 4:3 ones.)
    k.fx = k.fy = e.focal_length_35mm / 36.0 * long_side;
    if (plausible(k.fx)) {
      *camera = k;
      if (why) *why = "FocalLengthIn35mmFilm (36 mm across the long side)";
      if (refused) {
        *refused = reasons.str();
        while (!refused->empty() && (refused->back() == ' ' || refused->back() == ';')) refused->pop_back();
      }
      return true;
    }
    reasons << "FocalLengthIn35mmFilm " << e.focal_length_35mm << " mm gives " << k.fx << " px: absurd; ";
  }
  std::string text = reasons.str();
  if (e.focal_length_mm > 0 && !(e.focal_plane_x_resolution > 0))
    text += "FocalLength without FocalPlaneXResolution (the sensor size is unknown), no FocalLengthIn35mmFilm";
  if (text.empty()) text = "no FocalLength with FocalPlaneResolution, no FocalLengthIn35mmFilm";
  while (!text.empty() && (text.back() == ' ' || text.back() == ';')) text.pop_back();
  if (why) *why = text;
  return false;
}

}  // namespace freeloc::io
