#include "freeloc/matching/instance.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"

namespace freeloc::matching {

void InstanceOptions::Validate() const {
  FREELOC_CHECK(crop_margin >= 0 && crop_margin <= 2, "instance matching: crop margin must be in [0, 2]");
  FREELOC_CHECK(min_mask_pixels >= 0 && min_matches >= 0, "instance matching: minimums must be >= 0");
  match.Validate();
  fast_nn.Validate();
  descriptor_filter.Validate();
  preprocess.Validate();
}

namespace {

// Mask value at the original pixel nearest to network pixel (x, y).
uint8_t MaskAtNetworkPixel(const std::vector<uint8_t>& mask, int w, int h, const vision::Dust3rInput& in, int x,
                           int y) {
  double xo, yo;
  in.ToOriginal(x, y, &xo, &yo);
  const int xi = std::clamp(static_cast<int>(std::lround(xo)), 0, w - 1);
  const int yi = std::clamp(static_cast<int>(std::lround(yo)), 0, h - 1);
  return mask[static_cast<size_t>(yi) * w + xi];
}

std::vector<uint8_t> NetworkMask(const std::vector<uint8_t>& mask, int w, int h, const vision::Dust3rInput& in) {
  std::vector<uint8_t> out(static_cast<size_t>(in.width()) * in.height());
  for (int y = 0; y < in.height(); ++y)
    for (int x = 0; x < in.width(); ++x)
      out[static_cast<size_t>(y) * in.width() + x] = MaskAtNetworkPixel(mask, w, h, in, x, y);
  return out;
}

struct Box {
  int x0, y0, x1, y1;  // inclusive-exclusive
};

Box MaskBox(const std::vector<uint8_t>& m, int w, int h, double margin) {
  int x0 = w, y0 = h, x1 = -1, y1 = -1;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (m[static_cast<size_t>(y) * w + x]) {
        x0 = std::min(x0, x);
        y0 = std::min(y0, y);
        x1 = std::max(x1, x);
        y1 = std::max(y1, y);
      }
  const int bw = x1 - x0 + 1, bh = y1 - y0 + 1;
  const int mx = static_cast<int>(std::lround(margin * bw)), my = static_cast<int>(std::lround(margin * bh));
  return {std::max(0, x0 - mx), std::max(0, y0 - my), std::min(w, x1 + 1 + mx), std::min(h, y1 + 1 + my)};
}

// The image restricted to the mask (zero outside), optionally cropped to `box`; the mask cropped alike.
void Masked(const Image& img, const std::vector<uint8_t>& mask, const Box& box, Image* out,
            std::vector<uint8_t>* out_mask) {
  *out = Image(box.x1 - box.x0, box.y1 - box.y0);
  out_mask->assign(static_cast<size_t>(out->width) * out->height, 0);
  for (int y = box.y0; y < box.y1; ++y)
    for (int x = box.x0; x < box.x1; ++x) {
      const uint8_t m = mask[static_cast<size_t>(y) * img.width + x];
      (*out_mask)[static_cast<size_t>(y - box.y0) * out->width + (x - box.x0)] = m;
      if (!m) continue;
      const uint8_t* s = img.pixel(x, y);
      uint8_t* d = out->pixel(x - box.x0, y - box.y0);
      d[0] = s[0];
      d[1] = s[1];
      d[2] = s[2];
    }
}

std::vector<Correspondence> ToCorrespondences(const std::vector<PixelMatch>& m, const vision::Dust3rInput& a,
                                              const vision::Dust3rInput& b, int source, Eigen::Vector2d off_a,
                                              Eigen::Vector2d off_b) {
  std::vector<Correspondence> out;
  out.reserve(m.size());
  for (const PixelMatch& p : m) {
    double x1, y1, x2, y2;
    a.ToOriginal(p.x1, p.y1, &x1, &y1);
    b.ToOriginal(p.x2, p.y2, &x2, &y2);
    out.push_back(
        {Eigen::Vector2d(x1, y1) + off_a, Eigen::Vector2d(x2, y2) + off_b, std::min(p.conf1, p.conf2), source});
  }
  return out;
}

size_t Count(const std::vector<uint8_t>& m) {
  return static_cast<size_t>(std::count_if(m.begin(), m.end(), [](uint8_t v) { return v != 0; }));
}

}  // namespace

std::vector<Correspondence> GlobalCorrespondences(const PairPointmaps& pm, const vision::Dust3rInput& ref,
                                                  const vision::Dust3rInput& query, const ReciprocalOptions& options) {
  const auto m = ReciprocalMatches({pm.pts1.data(), pm.conf1.data(), nullptr, pm.h1, pm.w1},
                                   {pm.pts2.data(), pm.conf2.data(), nullptr, pm.h2, pm.w2}, options);
  return ToCorrespondences(m, ref, query, -1, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero());
}

std::vector<PixelMatch> MatchPair(const PairPointmaps& pm, const uint8_t* mask1, const uint8_t* mask2,
                                  const InstanceOptions& o) {
  if (!o.descriptors)
    return ReciprocalMatches({pm.pts1.data(), pm.conf1.data(), mask1, pm.h1, pm.w1},
                             {pm.pts2.data(), pm.conf2.data(), mask2, pm.h2, pm.w2}, o.match);
  FREELOC_CHECK(pm.desc_dim > 0 && !pm.desc1.empty() && !pm.desc2.empty(),
                "descriptor matching needs a MASt3R model (this pointmap model gives no descriptors)");
  const auto raw = FastReciprocalNN({pm.desc1.data(), pm.desc_conf1.data(), pm.h1, pm.w1, pm.desc_dim},
                                    {pm.desc2.data(), pm.desc_conf2.data(), pm.h2, pm.w2, pm.desc_dim}, o.fast_nn);
  std::vector<PixelMatch> out = FilterDescriptorMatches(raw, pm.w1, pm.h1, pm.w2, pm.h2, o.descriptor_filter);
  if (mask1 || mask2)
    out.erase(std::remove_if(out.begin(), out.end(),
                             [&](const PixelMatch& m) {
                               return (mask1 && !mask1[static_cast<size_t>(m.y1) * pm.w1 + m.x1]) ||
                                      (mask2 && !mask2[static_cast<size_t>(m.y2) * pm.w2 + m.x2]);
                             }),
              out.end());
  return out;
}

std::vector<Correspondence> GlobalCorrespondences(const PairPointmaps& pm, const vision::Dust3rInput& ref,
                                                  const vision::Dust3rInput& query, const InstanceOptions& options) {
  return ToCorrespondences(MatchPair(pm, nullptr, nullptr, options), ref, query, -1, Eigen::Vector2d::Zero(),
                           Eigen::Vector2d::Zero());
}

namespace {
Box ReferenceBox(const Image& ref, const std::vector<uint8_t>& mask, const InstanceOptions& o) {
  return o.mode == InstanceMode::kCrop ? MaskBox(mask, ref.width, ref.height, o.crop_margin)
                                       : Box{0, 0, ref.width, ref.height};
}
}  // namespace

vision::Dust3rInput InstanceReferenceInput(const Image& ref, const std::vector<uint8_t>& ref_mask,
                                           const InstanceOptions& o) {
  FREELOC_CHECK(ref_mask.size() == ref.num_pixels(), "instance reference mask: " << ref_mask.size() << " pixels for a "
                                                                                 << ref.width << "x" << ref.height
                                                                                 << " image");
  Image ir;
  std::vector<uint8_t> mr;
  Masked(ref, ref_mask, ReferenceBox(ref, ref_mask, o), &ir, &mr);
  return vision::PreprocessForDust3r(ir, o.preprocess);
}

InstanceResult MatchInstance(const Image& ref, const Image& query, const InstanceMasks& masks, const PointmapFn& model,
                             const InstanceOptions& o) {
  o.Validate();
  FREELOC_CHECK(masks.ref.size() == ref.num_pixels(), "instance " << masks.id << ": the reference mask has "
                                                                  << masks.ref.size() << " pixels but the image is "
                                                                  << ref.width << "x" << ref.height
                                                                  << "; masks must have their image's size");
  FREELOC_CHECK(masks.query.size() == query.num_pixels(),
                "instance " << masks.id << ": the query mask has " << masks.query.size() << " pixels but the image is "
                            << query.width << "x" << query.height << "; masks must have their image's size");
  InstanceResult r;
  r.id = masks.id;
  const size_t nr = Count(masks.ref), nq = Count(masks.query);
  if (static_cast<int>(std::min(nr, nq)) < o.min_mask_pixels) {
    r.reason = "mask too small (" + std::to_string(nr) + " / " + std::to_string(nq) + " px)";
    FREELOC_LOG(DEBUG) << "instance " << masks.id << " skipped: " << r.reason;
    return r;
  }
  const Box full_q{0, 0, query.width, query.height};
  const Box br = ReferenceBox(ref, masks.ref, o);
  const Box bq =
      o.mode == InstanceMode::kCrop ? MaskBox(masks.query, query.width, query.height, o.crop_margin) : full_q;
  Image ir, iq;
  std::vector<uint8_t> mr, mq;
  Masked(ref, masks.ref, br, &ir, &mr);
  Masked(query, masks.query, bq, &iq, &mq);
  const vision::Dust3rInput a = vision::PreprocessForDust3r(ir, o.preprocess);
  const vision::Dust3rInput b = vision::PreprocessForDust3r(iq, o.preprocess);
  const PairPointmaps pm = model(a, b);
  const std::vector<uint8_t> na = NetworkMask(mr, ir.width, ir.height, a), nb = NetworkMask(mq, iq.width, iq.height, b);
  const auto m = MatchPair(pm, na.data(), nb.data(), o);
  if (static_cast<int>(m.size()) < o.min_matches) {
    r.reason = "too few matches (" + std::to_string(m.size()) + ")";
    FREELOC_LOG(DEBUG) << "instance " << masks.id << " skipped: " << r.reason;
    return r;
  }
  r.matches = ToCorrespondences(m, a, b, masks.id, Eigen::Vector2d(br.x0, br.y0), Eigen::Vector2d(bq.x0, bq.y0));
  r.used = true;
  return r;
}

std::vector<Correspondence> MergeMatches(const std::vector<Correspondence>& global,
                                         const std::vector<InstanceResult>& instances,
                                         const std::vector<InstanceMasks>& masks, int w, int h) {
  // Union of the reference masks of the instances that produced matches.
  std::vector<uint8_t> covered(static_cast<size_t>(w) * h, 0);
  for (const InstanceResult& r : instances) {
    if (!r.used) continue;
    for (const InstanceMasks& m : masks) {
      if (m.id != r.id) continue;
      FREELOC_CHECK(m.ref.size() == covered.size(),
                    "merge: instance " << m.id << " mask size differs from the reference image");
      for (size_t i = 0; i < covered.size(); ++i) covered[i] |= m.ref[i] != 0;
    }
  }
  std::vector<Correspondence> out;
  for (const Correspondence& c : global) {
    const int x = std::clamp(static_cast<int>(std::lround(c.ref.x())), 0, w - 1);
    const int y = std::clamp(static_cast<int>(std::lround(c.ref.y())), 0, h - 1);
    if (!covered[static_cast<size_t>(y) * w + x]) out.push_back(c);
  }
  for (const InstanceResult& r : instances)
    if (r.used) out.insert(out.end(), r.matches.begin(), r.matches.end());
  return out;
}

std::vector<std::pair<int, std::vector<uint8_t>>> SplitLabels(const std::vector<uint16_t>& labels) {
  std::map<int, std::vector<uint8_t>> m;
  for (size_t i = 0; i < labels.size(); ++i) {
    if (!labels[i]) continue;
    auto& v = m[labels[i]];
    if (v.empty()) v.assign(labels.size(), 0);
    v[i] = 1;
  }
  return {m.begin(), m.end()};
}

}  // namespace freeloc::matching
