// `freeloc intrinsics IMG…`: what freeloc would use for each photo's intrinsics and why — its size as decoded, the
// EXIF orientation applied, the EXIF fields read and the camera they give (inputs/intrinsics.h, io/exif.h).
#include "freeloc/inputs/intrinsics.h"

#include <CLI/CLI.hpp>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/io/exif.h"
#include "freeloc/io/image_io.h"
#include "freeloc/pipeline/query_result.h"

namespace freeloc::cli {

namespace {

struct IntrinsicsArgs {
  std::vector<std::string> images;
  bool json = false;
};

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.6g", v);
  return buf;
}

// The EXIF fields freeloc reads, present ones only: "Make Apple; FocalLength 4.2 mm; …".
std::string ExifFieldsText(const io::ExifInfo& e) {
  std::string s;
  const auto add = [&](const std::string& t) { s += (s.empty() ? "" : "; ") + t; };
  if (!e.make.empty() || !e.model.empty()) add("camera " + e.make + (e.make.empty() ? "" : " ") + e.model);
  if (e.orientation) add("Orientation " + std::to_string(e.orientation));
  if (e.focal_length_mm > 0) add("FocalLength " + Num(e.focal_length_mm) + " mm");
  if (e.focal_length_35mm > 0) add("FocalLengthIn35mmFilm " + std::to_string(e.focal_length_35mm) + " mm");
  if (e.focal_plane_x_resolution > 0)
    add("FocalPlaneXResolution " + Num(e.focal_plane_x_resolution) +
        (e.focal_plane_y_resolution > 0 ? ", FocalPlaneYResolution " + Num(e.focal_plane_y_resolution) : "") + " per " +
        (e.focal_plane_unit == 3   ? "cm"
         : e.focal_plane_unit == 4 ? "mm"
         : e.focal_plane_unit == 5 ? "um"
                                   : "inch"));
  if (e.pixel_x_dimension > 0)
    add("PixelX/YDimension " + std::to_string(e.pixel_x_dimension) + "x" + std::to_string(e.pixel_y_dimension));
  for (const auto& p : e.problems) add("unusable: " + p);
  return s.empty() ? "none of the fields freeloc reads" : s;
}

int RunIntrinsics(const IntrinsicsArgs& a) {
  int failed = 0;
  for (const std::string& path : a.images) {
    io::ExifInfo exif;
    Image image;
    try {
      image = io::ReadImage(path, &exif);
    } catch (const Error& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      ++failed;
      continue;
    }
    const inputs::IntrinsicsChoice c =
        inputs::ChooseIntrinsics(nullptr, pipeline::IntrinsicsSource::kGiven, exif, image, true, path, false);
    const bool exif_k = c.source == pipeline::IntrinsicsSource::kExif;
    if (a.json) {
      nlohmann::json j = {{"image", path},
                          {"width", image.width},
                          {"height", image.height},
                          {"orientation", exif.orientation},
                          {"exif", exif.present},
                          {"source", exif_k ? "exif" : "pointmap"},
                          {"why", c.why}};
      if (exif_k) {
        j["fx"] = c.camera.fx;
        j["fy"] = c.camera.fy;
        j["cx"] = c.camera.cx;
        j["cy"] = c.camera.cy;
      }
      std::printf("%s\n", j.dump().c_str());
      continue;
    }
    std::printf("%s: %dx%d as displayed", path.c_str(), image.width, image.height);
    if (exif.transformed())
      std::printf(" (EXIF orientation %d: %s from the %dx%d stored)", exif.orientation,
                  io::OrientationText(exif.orientation).c_str(), exif.transposed() ? image.height : image.width,
                  exif.transposed() ? image.width : image.height);
    std::printf("\n  EXIF:       %s\n", exif.present ? ExifFieldsText(exif).c_str() : "none");
    if (exif_k)
      std::printf("  intrinsics: fx %.2f fy %.2f cx %.2f cy %.2f (exif: %s)\n", c.camera.fx, c.camera.fy, c.camera.cx,
                  c.camera.cy, c.why.c_str());
    else
      std::printf(
          "  intrinsics: none from the file (%s): a dust3r or mast3r preset estimates the focal from the "
          "pointmap; otherwise give --ref-intrinsics/--query-intrinsics or --intrinsics FILE\n",
          c.why.c_str());
  }
  return failed ? 1 : 0;
}

}  // namespace

void RegisterIntrinsics(CLI::App& app, const GlobalOptions&, RunFn* run) {
  auto a = std::make_shared<IntrinsicsArgs>();
  auto* sub = app.add_subcommand("intrinsics", "The intrinsics freeloc would use for each photo, and why (EXIF)");
  sub->add_option("images", a->images, "image files")->required();
  sub->add_flag("--json", a->json, "one JSON object per image");
  sub->callback([a, run] { *run = [a] { return RunIntrinsics(*a); }; });
}

}  // namespace freeloc::cli
