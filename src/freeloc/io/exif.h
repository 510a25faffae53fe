// EXIF metadata of a photo (libexif), read for two things: the Orientation tag (the decoder already shows the image
// upright, see image_io.h; this says that it did) and the camera's focal length, from which the intrinsics of a photo
// without a calibration follow (docs/geometry.md "Intrinsics without a calibration").
//
// EXIF is untrusted input: the APP1 segment is found by a bounded walk over the JPEG's marker segments (at most 64 KiB
// by the format), libexif parses it without "following the specification" (which would invent default values), and
// every value is checked for its type, count and range before it is used. Nothing here throws on bad metadata: a
// damaged or absurd field is left out and said in `problems`.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "freeloc/core/camera.h"

namespace freeloc::io {

struct ExifInfo {
  bool present = false;                 // an Exif APP1 segment was found and parsed
  int orientation = 0;                  // 1–8 as stored (0: no valid tag; 1: upright)
  double focal_length_mm = 0;           // FocalLength
  int focal_length_35mm = 0;            // FocalLengthIn35mmFilm
  double focal_plane_x_resolution = 0;  // FocalPlaneXResolution: pixels per unit along the stored image's x
  double focal_plane_y_resolution = 0;
  // FocalPlaneResolutionUnit: 2 inch (the default when absent: 0), 3 cm, 4 mm, 5 µm; −1 present but none of these (1
  // is "no absolute unit"): the focal plane resolution is then unusable, never read as inches.
  int focal_plane_unit = 0;
  int pixel_x_dimension = 0, pixel_y_dimension = 0;  // PixelX/YDimension: the stored image's size the tags describe
  std::string make, model;
  std::vector<std::string> problems;  // fields present but unusable, one line each

  // True when the decoder turned the stored pixels (orientation 2–8).
  bool transformed() const { return orientation >= 2 && orientation <= 8; }
  // True when the displayed image is the stored one turned by 90° (orientations 5–8: width and height swap).
  bool transposed() const { return orientation >= 5 && orientation <= 8; }
};

// The EXIF of an image file's bytes: JPEG APP1 "Exif" segments only (other formats give present = false).
ExifInfo ReadExif(const uint8_t* bytes, size_t size);
inline ExifInfo ReadExif(const std::vector<uint8_t>& bytes) { return ReadExif(bytes.data(), bytes.size()); }

// The orientation's words: "upright", "rotated 90° clockwise", …
std::string OrientationText(int orientation);

// Intrinsics from EXIF for the image as decoded (`width` × `height`, displayed orientation), principal point at the
// image centre ((w−1)/2, (h−1)/2: pixel centres at integers). The focal comes from FocalLength × FocalPlaneX/Y
// Resolution (scaled by width / PixelXDimension when the file was resized after the camera wrote the tags), else from
// FocalLengthIn35mmFilm with the 35 mm frame's 36 mm across the image's long side; fx and fy swap for orientations
// 5–8. False (and `why` says which fields were missing or absurd) when neither gives a focal between 0.1× and 20× the
// image's long side; `refused` (optional) says what was refused before the source used (empty when nothing was).
bool CameraFromExif(const ExifInfo& exif, int width, int height, Camera* camera, std::string* why,
                    std::string* refused = nullptr);

}  // namespace freeloc::io
