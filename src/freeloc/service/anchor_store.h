// The anchors of `freeloc serve` (docs/service.md): reference photos kept warm — each with its own pipeline
// Relocalizer whose reference work (depth, features or network encodings, instances) ran once, when the anchor was
// added — so that a query costs the query's work only. Optionally persisted to a folder (each anchor's upload and
// metadata written atomically) and reloaded at start.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "freeloc/core/image.h"
#include "freeloc/inputs/intrinsics.h"
#include "freeloc/pipeline/options.h"
#include "freeloc/pipeline/relocalizer.h"

namespace freeloc::service {

// One photo as uploaded: the image file's bytes, optionally a 16-bit depth PNG's bytes (millimetres, in the photo's
// displayed orientation) and intrinsics as "fx,fy,cx,cy" text.
struct PhotoUpload {
  std::vector<uint8_t> image;
  std::vector<uint8_t> depth;
  std::string intrinsics;
  std::string depth_unit;  // the unit of `depth`'s integers (mm, cm, m); empty: the server's depth_unit
};

// A photo decoded for the pipeline: upright image, intrinsics by freeloc's order (given > EXIF > pointmap), depth.
// Throws freeloc::Error naming `field` ("image", "depth", "intrinsics") for bad input.
struct DecodedPhoto {
  Image image;
  Camera camera;
  pipeline::FrameInputs inputs;
};
// `max_pixels` (> 0): a photo whose header declares more is refused before it is decoded.
DecodedPhoto DecodePhoto(const PhotoUpload& upload, const pipeline::PipelineOptions& options, const std::string& frame,
                         int64_t max_pixels = 0);

struct Anchor {
  std::string id;
  PhotoUpload upload;  // kept for persistence and for the web page (GET …/image)
  Image image;
  pipeline::FrameIntrinsics intrinsics;  // as the Relocalizer resolved them
  bool has_depth = false;
  double reference_ms = 0;  // the reference work, once
  int queries = 0;          // queries answered against it (under `mu`): each reused the reference work
  std::unique_ptr<pipeline::Relocalizer> reloc;
  std::mutex mu;  // one query at a time on this anchor's Relocalizer
};

class AnchorStore {
 public:
  // `store_dir` empty: in memory only. Anchors already in `store_dir` are loaded (their reference work runs again).
  AnchorStore(const pipeline::PipelineOptions& options, int max_anchors, const std::string& store_dir,
              int64_t max_pixels = 0);
  int64_t max_pixels() const { return max_pixels_; }

  // Adds an anchor and runs its reference work. Throws freeloc::Error for bad input (naming the field) and
  // StoreFull when max_anchors are held.
  std::shared_ptr<Anchor> Add(PhotoUpload upload);
  std::shared_ptr<Anchor> Get(const std::string& id) const;  // nullptr when unknown
  bool Remove(const std::string& id);
  std::vector<std::shared_ptr<Anchor>> List() const;
  size_t size() const;
  // The options a query against this anchor runs with (provided-depth presets without an anchor depth answer without
  // depth, as `freeloc relocalize` without depth files).
  const pipeline::PipelineOptions& options() const { return options_; }

  struct StoreFull : std::runtime_error {
    using std::runtime_error::runtime_error;
  };

 private:
  std::shared_ptr<Anchor> Make(const std::string& id, PhotoUpload upload) const;
  void Persist(const Anchor& a) const;
  pipeline::PipelineOptions options_;
  int max_anchors_;
  int64_t max_pixels_;
  std::string dir_;
  mutable std::mutex mu_;
  std::map<std::string, std::shared_ptr<Anchor>> anchors_;
};

}  // namespace freeloc::service
