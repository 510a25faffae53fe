// A fixture's PNG pair through freeloc's DUSt3R preprocessing: the "from PNGs" parity tests of DUSt3R and MASt3R.
#pragma once

#include <string>

#include "freeloc/io/image_io.h"
#include "freeloc/nn/dust3r.h"
#include "freeloc/vision/dust3r_preprocess.h"

namespace freeloc::testing {

// One case: the fixture case's name, its two image names (without ".png") and the preprocessing size.
struct PngPairCase {
  const char* name;
  const char* a;
  const char* b;
  int size;
};

struct PreprocessedPair {
  vision::Dust3rInput a, b;
  nn::Dust3rPrediction Run(const nn::Dust3rModel& model) const {
    return model.Run({a.normalized.data(), a.height(), a.width()}, {b.normalized.data(), b.height(), b.width()});
  }
};

// Reads `images_dir`/<a>.png and <b>.png and preprocesses both at the case's size.
inline PreprocessedPair PreprocessPngPair(const std::string& images_dir, const PngPairCase& c) {
  vision::Dust3rPreprocessOptions o;
  o.size = c.size;
  return {vision::PreprocessForDust3r(io::ReadImage(images_dir + "/" + c.a + ".png"), o),
          vision::PreprocessForDust3r(io::ReadImage(images_dir + "/" + c.b + ".png"), o)};
}

}  // namespace freeloc::testing
