// Resource limits on what input files may make freeloc allocate or walk. One process-wide table with
// documented defaults, overridable with the global `--limit NAME=VALUE` flag or `FREELOC_LIMIT_<NAME>` in the
// environment. Every limit hit is a one-line error naming the file and the limit (LimitHint).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "freeloc/core/option_family.h"

namespace freeloc {

struct InputLimits {
  int64_t max_image_pixels = 178'956'970;             // Pillow's MAX_IMAGE_PIXELS; checked from the header
  int64_t max_zip_member_bytes = int64_t{1} << 30;    // a compressed ZIP member's decompressed size
  int64_t max_submission_bytes = int64_t{256} << 20;  // one pose_*.txt in a submission
  int64_t max_tensors = 200'000;                      // tensors in one safetensors/.pth/.npz file
  int64_t max_pickle_objects = 2'000'000;             // values a .pth pickle may push (~250 bytes each)
};

// The limits in force (defaults, then FREELOC_LIMIT_* from the environment, then SetLimit).
const InputLimits& Limits();
// Sets one limit by name (max_image_pixels, …); throws freeloc::Error naming the choices for an unknown name or a
// value that is not a positive integer.
// Throws as SetLimit would, changing nothing (a command line checked before it runs).
void CheckLimit(const std::string& name, const std::string& value);
void SetLimit(const std::string& name, const std::string& value);
std::vector<std::string> LimitNames();
// The family "limits" (option_family.h): each limit's name, default and help.
const OptionFamily& LimitsFamily();
// "limit max_image_pixels = 178956970; raise it with --limit max_image_pixels=N" — for the end of a limit error.
std::string LimitHint(const std::string& name);

}  // namespace freeloc
