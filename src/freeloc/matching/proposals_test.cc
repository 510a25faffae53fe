#include "freeloc/matching/proposals.h"

#include <gtest/gtest.h>

#include <map>

#include "freeloc/core/error.h"

namespace freeloc::matching {
namespace {

// A fronto-parallel wall at 5 m with a box face at 3 m in the middle and a tilted floor strip at the bottom,
// seen by a pinhole camera: three surfaces the proposals must separate.
std::vector<float> Scene(int w, int h, std::vector<int>* truth) {
  std::vector<float> p(3 * static_cast<size_t>(w) * h);
  truth->assign(static_cast<size_t>(w) * h, 0);
  const double f = w, cx = (w - 1) / 2.0, cy = (h - 1) / 2.0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double z = 5.0;
      int id = 1;
      if (x > w / 3 && x < 2 * w / 3 && y > h / 4 && y < h / 2) {
        z = 3.0;
        id = 2;
      }
      if (y > 3 * h / 4) {  // floor: depth decreasing towards the bottom
        z = 5.0 * (3.0 * h / 4 - cy) / (y - cy);
        id = 3;
      }
      const size_t i = static_cast<size_t>(y) * w + x;
      p[3 * i] = static_cast<float>((x - cx) / f * z);
      p[3 * i + 1] = static_cast<float>((y - cy) / f * z);
      p[3 * i + 2] = static_cast<float>(z);
      (*truth)[i] = id;
    }
  return p;
}

TEST(Proposals, SeparatesSurfacesByDepthAndNormals) {
  const int w = 96, h = 72;
  std::vector<int> truth;
  const std::vector<float> pts = Scene(w, h, &truth);
  std::vector<float> conf(static_cast<size_t>(w) * h, 2.f);
  ProposalOptions o;
  o.conf_quantile = 0.0;
  const std::vector<uint16_t> labels = ProposeInstances(pts.data(), conf.data(), h, w, o);
  // Each true surface maps (mostly) to one label, and the three labels differ.
  std::map<int, std::map<int, int>> votes;
  for (size_t i = 0; i < labels.size(); ++i) ++votes[truth[i]][labels[i]];
  int majority[4] = {0, 0, 0, 0};
  for (int id = 1; id <= 3; ++id) {
    int best = -1, count = 0, total = 0;
    for (auto [l, c] : votes[id]) {
      total += c;
      if (l && c > count) {
        best = l;
        count = c;
      }
    }
    majority[id] = best;
    EXPECT_GT(count, 0.85 * total) << "surface " << id;
  }
  EXPECT_NE(majority[1], majority[2]);
  EXPECT_NE(majority[1], majority[3]);
  EXPECT_NE(majority[2], majority[3]);
  EXPECT_EQ(majority[1], 1);  // the largest, most confident surface ranks first
  // Deterministic.
  EXPECT_EQ(ProposeInstances(pts.data(), conf.data(), h, w, o), labels);
  // Low-confidence pixels are excluded: confidence low on the box → no label there.
  for (size_t i = 0; i < conf.size(); ++i)
    if (truth[i] == 2) conf[i] = 0.5f;
  o.conf_quantile = 0.2;
  const auto l2 = ProposeInstances(pts.data(), conf.data(), h, w, o);
  int box_labelled = 0;
  for (size_t i = 0; i < l2.size(); ++i) box_labelled += truth[i] == 2 && l2[i] != 0;
  EXPECT_LT(box_labelled, 50);
}

TEST(Proposals, MaxInstancesAndMapping) {
  const int w = 96, h = 72;
  std::vector<int> truth;
  const std::vector<float> pts = Scene(w, h, &truth);
  ProposalOptions o;
  o.max_instances = 1;
  const auto labels = ProposeInstances(pts.data(), nullptr, h, w, o);
  EXPECT_EQ(*std::max_element(labels.begin(), labels.end()), 1);
  // Back to an original image of 192×144 (network 96×72 after resize without crop at size 96).
  vision::Dust3rInput in;
  in.orig_width = 192;
  in.orig_height = 144;
  in.resized_width = 96;
  in.resized_height = 72;
  in.image = Image(96, 72);
  const auto full = ProposalsToImage(labels, in);
  ASSERT_EQ(full.size(), 192u * 144u);
  EXPECT_EQ(full[0], labels[0]);
  o.depth_jump = -1;
  EXPECT_THROW(o.Validate(), Error);
}

}  // namespace
}  // namespace freeloc::matching
