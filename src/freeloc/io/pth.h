// Reader for PyTorch zip checkpoints (torch.save since 1.6): `<archive>/data.pkl` (pickle) plus one record
// `<archive>/data/<key>` per storage. Tensors are rebuilt from torch._utils._rebuild_tensor_v2 (and
// _rebuild_parameter) honouring storage offsets, strides and shared storages; non-contiguous tensors are
// materialised contiguous. The legacy (pre-1.6, non-zip) format and TorchScript archives are refused clearly.
#pragma once

#include <string>
#include <vector>

#include "freeloc/io/pickle.h"
#include "freeloc/io/tensor.h"

namespace freeloc::io {

struct PthFile {
  std::string path;
  PyRef root;                        // the unpickled object; tensors appear as kTensor nodes (i = index below)
  std::vector<TensorView> tensors;   // contiguous tensors, indexed by the kTensor nodes
  std::vector<bool> was_contiguous;  // whether each tensor was stored contiguously (informational)

  static PthFile Open(const std::string& path);
};

}  // namespace freeloc::io
