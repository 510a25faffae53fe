#include "freeloc/nn/internal/torch_util.h"

#ifdef __GLIBC__
#include <malloc.h>
#endif

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "freeloc/core/error.h"
#include "freeloc/nn/internal/tensor_pool.h"

namespace freeloc::nn {

bool CudaAvailable() { return torch::cuda::is_available(); }

void ReleaseFreedMemory() {
  if (internal::TensorPool* pool = internal::InstalledTensorPool()) {
    pool->Trim();
  }
#ifdef __GLIBC__
  malloc_trim(0);
#endif
}

void ReleaseFreedMemory(const void* model) {
  internal::TensorPool* pool = internal::InstalledTensorPool();
  if (!pool) {
    ReleaseFreedMemory();
    return;
  }
  // glibc's heap (the tensors under 1 MiB) is trimmed when another model's pass begins: the same model's next pass
  // reuses its freed chunks instead of faulting them in again (malloc_trim itself took 20 ms).
  pool->Keep(model);
}

void BeginNetworkPass(const void* model) {
  internal::TensorPool* pool = internal::InstalledTensorPool();
  if (pool && !pool->Claim(model)) return;
#ifdef __GLIBC__
  malloc_trim(0);
#endif
}

namespace internal {

torch::Tensor ToTorch(const io::TensorView& t) {
  torch::Dtype d;
  switch (t.dtype) {
    case io::DType::kF32: d = torch::kFloat32; break;
    case io::DType::kF64: d = torch::kFloat64; break;
    case io::DType::kF16: d = torch::kFloat16; break;
    case io::DType::kBF16: d = torch::kBFloat16; break;
    case io::DType::kI64: d = torch::kInt64; break;
    case io::DType::kI32: d = torch::kInt32; break;
    case io::DType::kI16: d = torch::kInt16; break;
    case io::DType::kI8: d = torch::kInt8; break;
    case io::DType::kU8: d = torch::kUInt8; break;
    case io::DType::kBool: d = torch::kBool; break;
    default: FREELOC_THROW("unsupported dtype");
  }
  auto owner = new std::shared_ptr<const void>(t.owner);
  return torch::from_blob(
      const_cast<uint8_t*>(t.data), t.shape, [owner](void*) { delete owner; }, torch::TensorOptions().dtype(d));
}

io::TensorView ToView(const torch::Tensor& t_in) {
  torch::Tensor t = t_in.detach().to(torch::kCPU, torch::kFloat32).contiguous();
  io::TensorView v;
  v.dtype = io::DType::kF32;
  v.shape = t.sizes().vec();
  v.nbytes = static_cast<size_t>(t.numel()) * 4;
  auto holder = std::make_shared<torch::Tensor>(t);
  v.data = static_cast<const uint8_t*>(holder->data_ptr());
  v.owner = holder;
  return v;
}

void ApplyRuntime(const RuntimeOptions& runtime) {
  runtime.Validate();
  FREELOC_CHECK(runtime.device != Device::kCuda || CudaAvailable(),
                "device: cuda is not available in this LibTorch build; run on cpu or install a CUDA build of LibTorch");
  if (runtime.threads > 0) torch::set_num_threads(runtime.threads);
  if (runtime.device == Device::kCpu) InstallTensorPool();
}

std::string QuoteNonFiniteJson(const std::string& text) {
  std::string out;
  out.reserve(text.size() + 16);
  bool in_string = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      out += c;
      if (c == '\\' && i + 1 < text.size()) {
        out += text[++i];
      } else if (c == '"') {
        in_string = false;
      }
      continue;
    }
    if (c == '"') {
      in_string = true;
      out += c;
      continue;
    }
    auto word = [&](const char* w) { return text.compare(i, std::strlen(w), w) == 0; };
    if (word("-Infinity")) {
      out += "\"-inf\"";
      i += 8;
    } else if (word("Infinity")) {
      out += "\"inf\"";
      i += 7;
    } else if (word("NaN")) {
      out += "\"nan\"";
      i += 2;
    } else {
      out += c;
    }
  }
  return out;
}

nlohmann::json ParseModelConfig(const std::string& text, const std::string& source, const std::string& what) {
  try {
    return nlohmann::json::parse(QuoteNonFiniteJson(text));
  } catch (const std::exception& e) {
    FREELOC_THROW(source << ": the " << what << " config is not valid JSON (" << e.what() << ")");
  }
}

std::string ReadModelConfig(const std::string& model_path, const std::string& config_path, bool is_safetensors,
                            const std::string& what) {
  std::string file = config_path;
  if (file.empty()) {
    const auto sibling = std::filesystem::path(model_path).parent_path() / "config.json";
    if (is_safetensors && std::filesystem::exists(sibling)) file = sibling.string();
  }
  if (file.empty()) return "{}";
  std::ifstream f(file);
  FREELOC_CHECK(f.good(), file << ": cannot open the " << what << " config");
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

torch::Device DeviceOf(const RuntimeOptions& r) {
  return r.device == Device::kCuda ? torch::Device(torch::kCUDA) : torch::kCPU;
}

WeightStore::WeightStore(std::map<std::string, torch::Tensor> tensors, std::string source, torch::Device device,
                         bool own_copies)
    : tensors_(std::move(tensors)), source_(std::move(source)), device_(device), own_copies_(own_copies) {}

torch::Tensor WeightStore::Take(const std::string& name, const std::vector<int64_t>& shape) {
  auto it = tensors_.find(name);
  if (it == tensors_.end()) {
    missing_.push_back(name);
    return torch::Tensor();
  }
  used_.insert(name);
  torch::Tensor t = it->second;
  if (!shape.empty()) {
    bool ok = static_cast<int64_t>(shape.size()) == t.dim();
    for (size_t i = 0; ok && i < shape.size(); ++i) ok = shape[i] < 0 || shape[i] == t.size(static_cast<int64_t>(i));
    if (!ok) {
      std::ostringstream os;
      os << name << " " << t.sizes() << " (expected [";
      for (size_t i = 0; i < shape.size(); ++i) os << (i ? ", " : "") << shape[i];
      os << "])";
      wrong_shape_.push_back(os.str());
    }
  }
  if (!t.is_floating_point()) {
    // A weight stored as an integer type (a float's bits read as int32 once gave all-inf outputs) is refused.
    std::ostringstream os;
    os << name << " is " << t.scalar_type() << " (a network weight must be a floating-point tensor)";
    wrong_shape_.push_back(os.str());
  }
  if (t.scalar_type() != torch::kFloat32 || t.device() != device_)
    t = t.to(device_, torch::kFloat32);
  else if (own_copies_)
    t = t.clone();
  return t;
}

void WeightStore::Alias(const std::string& name, const std::string& same_as) {
  if (tensors_.count(name)) used_.insert(name);
  (void)same_as;
}

void WeightStore::Finish() const {
  std::vector<std::string> unexpected;
  for (const auto& [name, t] : tensors_)
    if (!used_.count(name)) unexpected.push_back(name);
  if (missing_.empty() && unexpected.empty() && wrong_shape_.empty()) return;
  std::ostringstream os;
  os << source_ << ": the weights do not match the model";
  auto list = [&](const char* what, const std::vector<std::string>& v) {
    if (v.empty()) return;
    os << "; " << v.size() << " " << what << ": ";
    for (size_t i = 0; i < v.size() && i < 12; ++i) os << (i ? ", " : "") << v[i];
    if (v.size() > 12) os << ", …";
  };
  list("missing", missing_);
  list("unexpected", unexpected);
  list("with the wrong shape", wrong_shape_);
  os << " — check that the file is the model you meant and that the config matches it";
  throw Error(os.str());
}

}  // namespace internal
}  // namespace freeloc::nn
