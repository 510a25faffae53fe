// One view over model checkpoints, whatever the file format: name → tensor (dtype, shape, bytes) and metadata,
// so nn/ never cares which file the weights came from.
//   * safetensors (HF `model.safetensors`, fixture files): names as stored, metadata = `__metadata__`;
//   * PyTorch zip `.pth`: every tensor in the pickled tree, named by its dotted path from the root
//     ("model.patch_embed.proj.weight"); metadata = every scalar (str/int/float/bool/None) in the tree by dotted
//     path, object fields included ("args.model" holds DUSt3R's constructor string).
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "freeloc/io/pickle.h"
#include "freeloc/io/tensor.h"

namespace freeloc::io {

class Checkpoint {
 public:
  enum class Format { kSafetensors, kPth };

  // Detects the format from the file's content. Throws freeloc::Error (naming the file) on anything unreadable.
  static Checkpoint Open(const std::string& path);

  const std::string& path() const { return path_; }
  Format format() const { return format_; }
  const char* format_name() const { return format_ == Format::kSafetensors ? "safetensors" : "pytorch-zip"; }

  const std::vector<std::string>& names() const { return names_; }  // file order
  size_t size() const { return names_.size(); }
  bool Has(const std::string& name) const { return tensors_.count(name) > 0; }
  const TensorView& Get(const std::string& name) const;  // throws naming the file and the tensor

  const std::map<std::string, std::string>& metadata() const { return metadata_; }
  // Metadata value or `fallback` when absent.
  std::string MetadataOr(const std::string& key, const std::string& fallback) const;

  // The pickled object tree of a .pth (nullptr for safetensors).
  const PyRef& root() const { return root_; }

  // The state dict: tensors under the first of `roots` that holds any ("model", "model_state_dict", …; "" = the
  // whole file), with that prefix removed from their names. Empty roots = the usual candidates.
  std::map<std::string, TensorView> StateDict(const std::vector<std::string>& roots = {}) const;
  // The root StateDict picked ("" when the tensors sit at the top level).
  std::string StateDictRoot(const std::vector<std::string>& roots = {}) const;

 private:
  std::string path_;
  Format format_ = Format::kSafetensors;
  std::vector<std::string> names_;
  std::map<std::string, TensorView> tensors_;
  std::map<std::string, std::string> metadata_;
  PyRef root_;
};

}  // namespace freeloc::io
