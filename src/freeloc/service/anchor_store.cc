#include "freeloc/service/anchor_store.h"

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/core/timing.h"
#include "freeloc/inputs/input_checks.h"
#include "freeloc/io/exif.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/image_io.h"
#include "freeloc/io/mapfree.h"

namespace freeloc::service {

namespace fs = std::filesystem;

DecodedPhoto DecodePhoto(const PhotoUpload& upload, const pipeline::PipelineOptions& o, const std::string& frame,
                         int64_t max_pixels) {
  DecodedPhoto p;
  FREELOC_CHECK(!upload.image.empty(), frame << " image: missing or empty; send the photo as the multipart field "
                                                "'image'");
  uint64_t w = 0, h = 0;
  if (max_pixels > 0 && io::ImageHeaderSize(upload.image, &w, &h))
    FREELOC_CHECK(w * h <= static_cast<uint64_t>(max_pixels),
                  frame << " image: declares " << w << " x " << h << " pixels, more than this server takes ("
                        << max_pixels / 1000000 << " MP, its max_upload_mp option); send a smaller photo");
  // At the working resolution, as `freeloc relocalize` reads a file (a JPEG decodes reduced): the same answer.
  p.image = io::DecodeImage(upload.image, frame + " image", o.WorkingMaxSide());
  const io::ExifInfo exif = io::ReadExif(upload.image);
  Camera given;
  const bool has_k = !upload.intrinsics.empty();
  if (has_k) given = Camera::FromString(upload.intrinsics, frame + " intrinsics");
  const inputs::IntrinsicsChoice c = inputs::ChooseIntrinsics(
      has_k ? &given : nullptr, pipeline::IntrinsicsSource::kGiven, exif, p.image, o.UsesPointmapModel(), frame);
  FREELOC_CHECK(c.source != pipeline::IntrinsicsSource::kNone,
                frame << " intrinsics: none given and the photo's EXIF has no usable focal length (" << c.why
                      << "); send 'intrinsics' as fx,fy,cx,cy, or serve a dust3r or mast3r preset (they estimate "
                         "the focal from the pointmap)");
  p.camera = pipeline::ApplyIntrinsics(c, &p.inputs);
  if (!upload.depth.empty()) {
    p.inputs.depth = io::DecodeDepthPng(upload.depth, frame + " depth");
    p.inputs.depth.source.clear();  // the messages say "<frame> depth" already
    // A unit sent with the map applies to it; otherwise the Relocalizer applies the server's (its size, unit and
    // plausibility are the pipeline's one rule, inputs/input_checks.h).
    if (!upload.depth_unit.empty()) {
      pipeline::DepthUnit unit;
      FREELOC_CHECK(TryParseEnum(upload.depth_unit, &unit), frame << " depth_unit: '" << SafeText(upload.depth_unit, 20)
                                                                  << "' is not one of "
                                                                  << EnumNames<pipeline::DepthUnit>());
      inputs::ApplyDepthUnit(unit, &p.inputs.depth);
    }
  }
  return p;
}

namespace {

std::string NewId() {
  static std::mt19937_64 rng(std::random_device{}() ^
                             static_cast<uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count()));
  static std::mutex mu;
  std::lock_guard<std::mutex> lock(mu);
  char buf[17];
  std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(rng()));
  return buf;
}

// A stored anchor's upload (DIR/<id>/meta.json, image, depth.png) checked field by field: an Error naming what is
// wrong, never a parser's raw text.
PhotoUpload ReadStored(const fs::path& d) {
  const std::string path = (d / "meta.json").string();
  const std::vector<uint8_t> bytes = io::ReadFileBytes(path);
  FREELOC_CHECK(bytes.size() <= 4096, "meta.json: " << bytes.size() << " bytes, more than an anchor's metadata");
  const nlohmann::json meta = nlohmann::json::parse(bytes.begin(), bytes.end(), nullptr, false);
  FREELOC_CHECK(meta.is_object(), "meta.json: not a JSON object (truncated or overwritten?)");
  const auto field = [&](const char* name, nlohmann::json::value_t type, const char* what) {
    const auto it = meta.find(name);
    FREELOC_CHECK(it == meta.end() || it->type() == type, "meta.json: '" << name << "' is not " << what);
  };
  field("intrinsics", nlohmann::json::value_t::string, "text");
  field("depth", nlohmann::json::value_t::boolean, "true or false");
  field("depth_unit", nlohmann::json::value_t::string, "text");
  PhotoUpload u;
  u.image = io::ReadFileBytes((d / "image").string());
  if (meta.value("depth", false)) u.depth = io::ReadFileBytes((d / "depth.png").string());
  u.intrinsics = meta.value("intrinsics", std::string());
  u.depth_unit = meta.value("depth_unit", std::string());
  return u;
}

bool ValidId(const std::string& id) {
  if (id.size() != 16) return false;
  for (char c : id)
    if (!std::isxdigit(static_cast<unsigned char>(c))) return false;
  return true;
}

}  // namespace

AnchorStore::AnchorStore(const pipeline::PipelineOptions& options, int max_anchors, const std::string& store_dir,
                         int64_t max_pixels)
    : options_(options), max_anchors_(max_anchors), max_pixels_(max_pixels), dir_(store_dir) {
  FREELOC_CHECK(max_anchors >= 1, "max_anchors: " << max_anchors << " must be at least 1");
  if (dir_.empty()) return;
  std::error_code ec;
  fs::create_directories(dir_, ec);
  FREELOC_CHECK(!ec, dir_ << ": cannot create the anchor store folder (" << ec.message() << ")");
  for (const auto& entry : fs::directory_iterator(dir_)) {
    const std::string id = entry.path().filename().string();
    if (!entry.is_directory() || !ValidId(id) || !fs::exists(entry.path() / "meta.json")) continue;
    try {
      if (static_cast<int>(anchors_.size()) >= max_anchors_) break;
      anchors_[id] = Make(id, ReadStored(entry.path()));
    } catch (const std::exception& e) {
      // A damaged anchor is set aside, not retried at every start, and the others load.
      const fs::path q = fs::path(dir_) / "quarantine" / id;
      std::error_code qec;
      fs::create_directories(q.parent_path(), qec);
      fs::remove_all(q, qec);
      fs::rename(entry.path(), q, qec);
      FREELOC_LOG(WARNING) << entry.path().string() << ": anchor not reloaded (" << e.what() << "); "
                           << (qec ? "left in place (cannot move it: " + qec.message() + ")"
                                   : "moved to " + q.string() + " — delete it, or fix it and move it back");
    }
  }
  FREELOC_LOG(INFO) << dir_ << ": " << anchors_.size() << " anchors reloaded";
}

std::shared_ptr<Anchor> AnchorStore::Make(const std::string& id, PhotoUpload upload) const {
  auto a = std::make_shared<Anchor>();
  a->id = id;
  a->has_depth = !upload.depth.empty();
  pipeline::PipelineOptions o = options_;
  // As `freeloc relocalize` without depth files: the provided-depth presets answer without depth.
  if (!a->has_depth && o.UsesProvidedDepth()) o.depth = pipeline::DepthSpec::FromString("none");
  DecodedPhoto p = DecodePhoto(upload, o, "anchor", max_pixels_);
  a->upload = std::move(upload);
  a->image = std::move(p.image);
  const auto t0 = std::chrono::steady_clock::now();
  a->reloc = std::make_unique<pipeline::Relocalizer>(o, pipeline::Relocalizer::kOptionsValidated);  // by the server
  a->reloc->SetReference(a->image, p.camera, std::move(p.inputs));
  a->reference_ms = MsSince(t0);
  // The intrinsics as resolved (the pointmap's when it gave them): what a query's record reports for the reference.
  a->intrinsics = a->reloc->reference_intrinsics();
  return a;
}

void AnchorStore::Persist(const Anchor& a) const {
  if (dir_.empty()) return;
  const fs::path d = fs::path(dir_) / a.id;
  fs::create_directories(d);
  io::WriteFileAtomic((d / "image").string(), a.upload.image.data(), a.upload.image.size());
  if (a.has_depth) io::WriteFileAtomic((d / "depth.png").string(), a.upload.depth.data(), a.upload.depth.size());
  const std::string meta =
      nlohmann::json{{"intrinsics", a.upload.intrinsics}, {"depth", a.has_depth}, {"depth_unit", a.upload.depth_unit}}
          .dump();  // last: marks it complete
  io::WriteFileAtomic((d / "meta.json").string(), meta.data(), meta.size());
}

std::shared_ptr<Anchor> AnchorStore::Add(PhotoUpload upload) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (static_cast<int>(anchors_.size()) >= max_anchors_)
      throw StoreFull(
          "the service holds its maximum of " + std::to_string(max_anchors_) +
          " anchors (max_anchors); delete some (DELETE /v1/anchors/{id}) or start the service with a larger limit");
  }
  std::shared_ptr<Anchor> a = Make(NewId(), std::move(upload));
  Persist(*a);
  std::lock_guard<std::mutex> lock(mu_);
  if (static_cast<int>(anchors_.size()) >= max_anchors_) throw StoreFull("the service holds its maximum of anchors");
  anchors_[a->id] = a;
  return a;
}

std::shared_ptr<Anchor> AnchorStore::Get(const std::string& id) const {
  std::lock_guard<std::mutex> lock(mu_);
  const auto it = anchors_.find(id);
  return it == anchors_.end() ? nullptr : it->second;
}

bool AnchorStore::Remove(const std::string& id) {
  std::lock_guard<std::mutex> lock(mu_);
  if (!anchors_.erase(id)) return false;
  if (!dir_.empty() && ValidId(id)) {
    std::error_code ec;
    fs::remove((fs::path(dir_) / id / "meta.json"), ec);  // first: a half-removed anchor is never reloaded
    fs::remove_all(fs::path(dir_) / id, ec);
  }
  return true;
}

std::vector<std::shared_ptr<Anchor>> AnchorStore::List() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<std::shared_ptr<Anchor>> out;
  for (const auto& [id, a] : anchors_) out.push_back(a);
  return out;
}

size_t AnchorStore::size() const {
  std::lock_guard<std::mutex> lock(mu_);
  return anchors_.size();
}

}  // namespace freeloc::service
