#include "freeloc/io/image_io.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "freeloc/core/error.h"
#include "freeloc/core/limits.h"
#include "freeloc/core/logging.h"
#include "freeloc/core/module_loader.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/internal/codecs_api.h"
#include "freeloc/io/internal/png.h"

namespace freeloc::io {

ImageFormat SniffImageFormat(const uint8_t* b, size_t n) {
  if (n >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF) return ImageFormat::kJpeg;
  if (n >= 8 && std::memcmp(b, "\x89PNG\r\n\x1a\n", 8) == 0) return ImageFormat::kPng;
  if (n >= 2 && b[0] == 'B' && b[1] == 'M') return ImageFormat::kBmp;
  if (n >= 4 && (std::memcmp(b, "II*\0", 4) == 0 || std::memcmp(b, "MM\0*", 4) == 0)) return ImageFormat::kTiff;
  if (n >= 12 && std::memcmp(b, "RIFF", 4) == 0 && std::memcmp(b + 8, "WEBP", 4) == 0) return ImageFormat::kWebp;
  return ImageFormat::kUnknown;
}

const char* ImageFormatName(ImageFormat f) {
  switch (f) {
    case ImageFormat::kJpeg: return "JPEG";
    case ImageFormat::kPng: return "PNG";
    case ImageFormat::kBmp: return "BMP";
    case ImageFormat::kTiff: return "TIFF";
    case ImageFormat::kWebp: return "WebP";
    default: return "unknown";
  }
}

namespace {

ImageFormat FormatFromExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".jpg" || ext == ".jpeg") return ImageFormat::kJpeg;
  if (ext == ".png") return ImageFormat::kPng;
  if (ext == ".bmp") return ImageFormat::kBmp;
  if (ext == ".tif" || ext == ".tiff") return ImageFormat::kTiff;
  if (ext == ".webp") return ImageFormat::kWebp;
  return ImageFormat::kUnknown;
}

// Walks a JPEG's segments from SOI to EOI, the way a decoder meets them: each marker segment must lie inside the file,
// a frame header and a scan must come before the end-of-image marker, and each scan's entropy-coded data must end in
// a marker. "" when complete, else what is wrong. (An FF D9 near the end is not enough: an EXIF thumbnail holds its
// own, so a file cut after its APP1 segment once passed.)
std::string JpegStructureProblem(const std::vector<uint8_t>& b) {
  const size_t n = b.size();
  size_t k = 2;  // after SOI
  bool frame = false, scan = false;
  while (true) {
    if (k >= n) return "ends before its end-of-image marker";
    if (b[k] != 0xFF) return "has data outside a segment at byte " + std::to_string(k);
    while (k < n && b[k] == 0xFF) ++k;  // fill bytes
    if (k >= n) return "ends before its end-of-image marker";
    const uint8_t m = b[k++];
    if (m == 0xD9) {
      if (!frame || !scan) return "ends without image data (no frame header or scan before the end-of-image marker)";
      return "";
    }
    if ((m >= 0xD0 && m <= 0xD7) || m == 0x01) continue;  // standalone markers
    if (k + 2 > n) return "ends inside a marker segment";
    const size_t len = (size_t{b[k]} << 8) | b[k + 1];
    if (len < 2 || k + len > n) return "ends inside a marker segment (truncated)";
    if (m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC) frame = true;
    k += len;
    if (m != 0xDA) continue;
    if (!frame) return "has a scan before its frame header";
    scan = true;
    // Entropy-coded data: ends at the first FF that is neither stuffing (FF 00) nor a restart marker.
    while (true) {
      while (k < n && b[k] != 0xFF) ++k;
      if (k + 1 >= n) return "ends inside its image data (truncated)";
      const uint8_t next = b[k + 1];
      if (next == 0x00 || (next >= 0xD0 && next <= 0xD7) || next == 0xFF) {
        k += next == 0xFF ? 1 : 2;
        continue;
      }
      break;
    }
  }
}

// libjpeg and libpng "recover" from truncation by padding with grey; we refuse such files instead.
void CheckComplete(ImageFormat f, const std::vector<uint8_t>& b, const std::string& what) {
  const std::string fix = "; the file is truncated or damaged — copy or download it again";
  if (f == ImageFormat::kJpeg) {
    const std::string problem = JpegStructureProblem(b);
    FREELOC_CHECK(problem.empty(), what << ": JPEG " << problem << fix);
  } else if (f == ImageFormat::kPng) {
    const size_t tail = std::min<size_t>(b.size(), 64);
    bool found = false;
    for (size_t k = b.size() - tail; k + 4 <= b.size(); ++k) {
      if (std::memcmp(&b[k], "IEND", 4) == 0) found = true;
    }
    FREELOC_CHECK(found, what << ": PNG has no IEND chunk" << fix);
  }
}

uint32_t Be32(const uint8_t* p) { return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (p[2] << 8) | p[3]; }
uint32_t Le32(const uint8_t* p) { return (uint32_t{p[3]} << 24) | (uint32_t{p[2]} << 16) | (p[1] << 8) | p[0]; }
uint16_t Get16(const uint8_t* p, bool big) { return big ? (p[0] << 8) | p[1] : (p[1] << 8) | p[0]; }

// TIFF: ImageWidth (256) and ImageLength (257) of the first IFD.
bool TiffDimensions(const std::vector<uint8_t>& b, uint64_t* w, uint64_t* h) {
  if (b.size() < 8) return false;
  const bool big = b[0] == 'M';
  const uint32_t ifd = big ? Be32(&b[4]) : Le32(&b[4]);
  if (ifd > b.size() - 2) return false;
  const size_t n = Get16(&b[ifd], big);
  for (size_t k = 0; k < n; ++k) {
    const size_t e = ifd + 2 + 12 * k;
    if (e + 12 > b.size()) return false;
    const uint16_t tag = Get16(&b[e], big), type = Get16(&b[e + 2], big);
    const uint64_t v = type == 3 ? Get16(&b[e + 8], big) : (big ? Be32(&b[e + 8]) : Le32(&b[e + 8]));
    if (tag == 256) *w = v;
    if (tag == 257) *h = v;
  }
  return *w > 0 && *h > 0;
}

// The image size from the header alone, for PNG, JPEG, BMP, TIFF and WebP; false when it cannot be read (the decoder
// then reports the damage).
bool HeaderDimensions(ImageFormat f, const std::vector<uint8_t>& b, uint64_t* w, uint64_t* h) {
  *w = *h = 0;
  switch (f) {
    case ImageFormat::kPng:
      if (b.size() < 24) return false;
      *w = Be32(&b[16]);
      *h = Be32(&b[20]);
      return true;
    case ImageFormat::kJpeg: {
      size_t k = 2;
      while (k + 9 < b.size()) {
        if (b[k] != 0xFF) return false;
        const uint8_t m = b[k + 1];
        if (m == 0xFF) {
          ++k;
          continue;
        }
        const size_t len = (b[k + 2] << 8) | b[k + 3];
        const bool sof = m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC;
        if (sof) {
          *h = (b[k + 5] << 8) | b[k + 6];
          *w = (b[k + 7] << 8) | b[k + 8];
          return true;
        }
        if (len < 2) return false;
        k += 2 + len;
      }
      return false;
    }
    case ImageFormat::kBmp: {
      if (b.size() < 26) return false;
      const int32_t bw = static_cast<int32_t>(Le32(&b[18])), bh = static_cast<int32_t>(Le32(&b[22]));
      *w = static_cast<uint64_t>(std::abs(static_cast<int64_t>(bw)));
      *h = static_cast<uint64_t>(std::abs(static_cast<int64_t>(bh)));
      return true;
    }
    case ImageFormat::kTiff: return TiffDimensions(b, w, h);
    case ImageFormat::kWebp: {
      if (b.size() < 30) return false;
      if (std::memcmp(&b[12], "VP8X", 4) == 0) {
        *w = 1 + (b[24] | (b[25] << 8) | (uint32_t{b[26]} << 16));
        *h = 1 + (b[27] | (b[28] << 8) | (uint32_t{b[29]} << 16));
      } else if (std::memcmp(&b[12], "VP8L", 4) == 0) {
        const uint32_t bits = Le32(&b[21]);
        *w = 1 + (bits & 0x3FFF);
        *h = 1 + ((bits >> 14) & 0x3FFF);
      } else {
        *w = (b[26] | (b[27] << 8)) & 0x3FFF;
        *h = (b[28] | (b[29] << 8)) & 0x3FFF;
      }
      return true;
    }
    default: return false;
  }
}

// Refuses, before any decoding, an image whose header declares more pixels than the limit (a 0.87 MB PNG can
// declare 30000 x 30000 and decode into gigabytes).
void CheckPixelLimit(ImageFormat f, const std::vector<uint8_t>& b, const std::string& what) {
  uint64_t w = 0, h = 0;
  if (!HeaderDimensions(f, b, &w, &h)) return;
  const uint64_t limit = static_cast<uint64_t>(Limits().max_image_pixels);
  FREELOC_CHECK(w <= limit && h <= limit && w * h <= limit, what << ": " << ImageFormatName(f) << " declares " << w
                                                                 << " x " << h << " pixels, beyond the "
                                                                 << LimitHint("max_image_pixels"));
}

// The stored image turned as EXIF `orientation` (1–8) says it is displayed: 2 mirrored left-right, 3 turned 180°,
// 4 mirrored top-bottom, 5 transposed, 6 turned 90° clockwise, 7 transversed, 8 turned 90° counter-clockwise.
Image Oriented(const Image& in, int orientation) {
  if (orientation < 2 || orientation > 8) return in;
  const int W = in.width, H = in.height;
  const bool turned = orientation >= 5;
  Image out(turned ? H : W, turned ? W : H);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      int sx = x, sy = y;  // the stored pixel shown at (x, y)
      switch (orientation) {
        case 2: sx = W - 1 - x; break;
        case 3: sx = W - 1 - x, sy = H - 1 - y; break;
        case 4: sy = H - 1 - y; break;
        case 5: sx = y, sy = x; break;
        case 6: sx = y, sy = H - 1 - x; break;
        case 7: sx = W - 1 - y, sy = H - 1 - x; break;
        case 8: sx = W - 1 - y, sy = x; break;
      }
      const uint8_t* p = &in.data[(static_cast<size_t>(sy) * W + sx) * 3];
      uint8_t* q = &out.data[(static_cast<size_t>(y) * out.width + x) * 3];
      q[0] = p[0], q[1] = p[1], q[2] = p[2];
    }
  return out;
}

// The codecs module's decode at 1/`reduce` of the size, turned upright by the EXIF orientation freeloc reads (one
// reading for the image and for what `intrinsics` and the records report); throws naming `what` when the data cannot
// be decoded.
void DecodeWith(ImageFormat f, const std::vector<uint8_t>& bytes, const std::string& what, int reduce, Image* img) {
  std::string error;
  if (!internal::Codecs().decode_rgb_reduced(bytes.data(), bytes.size(), reduce, img, &error)) {
    FREELOC_THROW(what << ": cannot decode the " << ImageFormatName(f) << " data"
                       << (error.empty() ? "" : " (" + SafeText(error, 300) + ")") << "; the file is damaged");
  }
  if (f == ImageFormat::kJpeg) {
    const int orientation = ReadExif(bytes).orientation;
    if (orientation >= 2) *img = Oriented(*img, orientation);
  }
}

}  // namespace

void WorkingSize(int width, int height, int max_side, int* w, int* h) {
  *w = width;
  *h = height;
  const int side = std::max(width, height);
  if (max_side <= 0 || side <= max_side) return;
  const double s = static_cast<double>(max_side) / side;
  *w = std::max(1, static_cast<int>(std::lround(width * s)));
  *h = std::max(1, static_cast<int>(std::lround(height * s)));
}

Image ShrinkImage(const Image& image, int width, int height) {
  FREELOC_CHECK(
      width > 0 && height > 0 && width <= image.width && height <= image.height,
      "ShrinkImage: " << width << "x" << height << " is not a reduction of " << image.width << "x" << image.height);
  Image out;
  std::string error;
  FREELOC_CHECK(internal::Codecs().resize_area(image, width, height, &out, &error),
                "resizing a photo: " << SafeText(error, 300));
  out.photo_width = image.PhotoWidth();
  out.photo_height = image.PhotoHeight();
  return out;
}

Image DecodeImage(const std::vector<uint8_t>& bytes, const std::string& what, int max_side) {
  const ImageFormat f = bytes.empty() ? ImageFormat::kUnknown : SniffImageFormat(bytes.data(), bytes.size());
  uint64_t sw = 0, sh = 0;
  if (max_side > 0 && f == ImageFormat::kJpeg && HeaderDimensions(f, bytes, &sw, &sh) &&
      std::max(sw, sh) > static_cast<uint64_t>(max_side)) {
    // JPEG's scaled decoding: the largest of 1/8, 1/4, 1/2 that keeps the long side at least max_side, then an area
    // resize to the working size. The photo's displayed size (its EXIF orientation turns the stored one) is kept.
    CheckComplete(f, bytes, what);
    CheckPixelLimit(f, bytes, what);
    const int orientation = ReadExif(bytes).orientation;
    const bool turned = orientation >= 5 && orientation <= 8;
    const int photo_w = static_cast<int>(turned ? sh : sw), photo_h = static_cast<int>(turned ? sw : sh);
    const int side = std::max(photo_w, photo_h);
    int reduce = 1;
    for (int k : {8, 4, 2})
      if ((side + k - 1) / k >= max_side) {
        reduce = k;
        break;
      }
    Image img;
    DecodeWith(f, bytes, what, reduce, &img);
    // libjpeg rounds each reduced side up: anything else (an orientation not applied as read) decodes in full below.
    if (img.width == (photo_w + reduce - 1) / reduce && img.height == (photo_h + reduce - 1) / reduce) {
      img.photo_width = photo_w;
      img.photo_height = photo_h;
      int w, h;
      WorkingSize(photo_w, photo_h, max_side, &w, &h);
      return img.width == w && img.height == h ? img : ShrinkImage(img, w, h);
    }
  }
  Image full = DecodeImage(bytes, what);
  int w, h;
  WorkingSize(full.width, full.height, max_side, &w, &h);
  return w == full.width && h == full.height ? full : ShrinkImage(full, w, h);
}

Image DecodeImage(const std::vector<uint8_t>& bytes, const std::string& what) {
  FREELOC_CHECK(!bytes.empty(), what << ": file is empty; expected a JPEG or PNG image");
  const ImageFormat f = SniffImageFormat(bytes.data(), bytes.size());
  FREELOC_CHECK(f != ImageFormat::kUnknown,
                what << ": not a supported image (expected JPEG, PNG, BMP, TIFF or WebP content); check the file");
  CheckComplete(f, bytes, what);
  CheckPixelLimit(f, bytes, what);
  Image img;
  if (f == ImageFormat::kPng && bytes.size() > 25 && bytes[24] == 16 && bytes[25] == 0) {
    // 16-bit greyscale: Pillow, which the networks' reference preprocessing uses, converts it to RGB by clipping each
    // value to 255 (mode I;16 → RGB); OpenCV would keep the high byte. Decoded here as Pillow does.
    int w = 0, h = 0, bits = 0;
    const std::vector<uint16_t> v = internal::DecodeGreyPng(bytes, what, &w, &h, &bits);
    img.width = w;
    img.height = h;
    img.data.resize(static_cast<size_t>(w) * h * 3);
    for (size_t i = 0; i < v.size(); ++i) {
      const uint8_t g = static_cast<uint8_t>(std::min<uint16_t>(v[i], 255));
      img.data[3 * i] = img.data[3 * i + 1] = img.data[3 * i + 2] = g;
    }
    return img;
  }
  DecodeWith(f, bytes, what, 1, &img);
  return img;
}

Image ReadImage(const std::string& path) { return ReadImage(path, nullptr); }

Image ReadImage(const std::string& path, ExifInfo* exif) { return ReadImage(path, exif, 0); }

Image ReadImage(const std::string& path, ExifInfo* exif, int max_side) {
  const std::vector<uint8_t> bytes = ReadFileBytes(path);
  if (!bytes.empty()) {
    const ImageFormat content = SniffImageFormat(bytes.data(), bytes.size());
    const ImageFormat ext = FormatFromExtension(path);
    if (content != ImageFormat::kUnknown && ext != ImageFormat::kUnknown && content != ext) {
      FREELOC_LOG(WARNING) << path << ": extension says " << ImageFormatName(ext) << " but the content is "
                           << ImageFormatName(content) << "; decoding it as " << ImageFormatName(content);
    }
  }
  Image image = DecodeImage(bytes, path, max_side);
  if (exif) *exif = ReadExif(bytes);
  return image;
}

void WriteImagePng(const std::string& path, const Image& image) {
  FREELOC_CHECK(!image.empty(), path << ": refusing to write an empty image");
  const auto buf = internal::EncodePng(image.data.data(), image.width, image.height, 3, 8, path);
  WriteFileAtomic(path, buf.data(), buf.size());
}

void WritePng8(const std::string& path, int width, int height, const std::vector<uint8_t>& values) {
  FREELOC_CHECK(width > 0 && height > 0 && values.size() == static_cast<size_t>(width) * height,
                path << ": 8-bit PNG size does not match its data");
  const auto buf = internal::EncodePng(values.data(), width, height, 1, 8, path);
  WriteFileAtomic(path, buf.data(), buf.size());
}

void WritePng16(const std::string& path, int width, int height, const std::vector<uint16_t>& values) {
  FREELOC_CHECK(width > 0 && height > 0 && values.size() == static_cast<size_t>(width) * height,
                path << ": 16-bit PNG size does not match its data");
  const auto buf = internal::EncodePng(values.data(), width, height, 1, 16, path);
  WriteFileAtomic(path, buf.data(), buf.size());
}

std::vector<uint16_t> ReadPng16(const std::string& path, int* width, int* height, int* bits) {
  return DecodePng16(ReadFileBytes(path), path, width, height, bits);
}

std::vector<uint16_t> DecodePng16(const std::vector<uint8_t>& bytes, const std::string& what, int* width, int* height,
                                  int* bits) {
  FREELOC_CHECK(SniffImageFormat(bytes.data(), bytes.size()) == ImageFormat::kPng,
                what << ": not a PNG file; depth maps must be 16-bit PNGs");
  CheckComplete(ImageFormat::kPng, bytes, what);
  CheckPixelLimit(ImageFormat::kPng, bytes, what);
  return internal::DecodeGreyPng(bytes, what, width, height, bits);
}

std::vector<uint8_t> EncodeJpeg(const Image& rgb, int quality, const std::string& what) {
  FREELOC_CHECK(!rgb.empty(), what << ": refusing to encode an empty image");
  std::vector<uint8_t> out;
  std::string error;
  FREELOC_CHECK(internal::Codecs().encode_jpeg(rgb, quality, &out, &error),
                what << ": cannot encode the JPEG (" << SafeText(error, 300) << ")");
  return out;
}

namespace internal {

const CodecsApi& Codecs() {
  static const CodecsApi& api = LoadModuleTable<CodecsApi>(kCodecsLibrary, kCodecsEntry, kCodecsAbi, "image decoding");
  return api;
}

}  // namespace internal

}  // namespace freeloc::io

namespace freeloc::io {

bool ImageHeaderSize(const std::vector<uint8_t>& bytes, uint64_t* width, uint64_t* height) {
  if (bytes.empty()) return false;
  return HeaderDimensions(SniffImageFormat(bytes.data(), bytes.size()), bytes, width, height);
}

}  // namespace freeloc::io
