#include "freeloc/io/checkpoint.h"

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "freeloc/core/error.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/pth.h"
#include "freeloc/io/safetensors.h"

namespace freeloc::io {

namespace {

std::string Join(const std::string& prefix, const std::string& key) {
  return prefix.empty() ? key : prefix + "." + key;
}

std::string KeyString(const PyRef& k) {
  if (k->is(PyObject::Kind::kStr)) return k->s;
  if (k->is(PyObject::Kind::kInt)) return std::to_string(k->i);
  return k->Repr(100);
}

std::string ScalarString(const PyRef& v) {
  switch (v->kind) {
    case PyObject::Kind::kStr: return v->s;
    case PyObject::Kind::kNone: return "None";
    case PyObject::Kind::kBool: return v->b ? "True" : "False";
    case PyObject::Kind::kInt: return std::to_string(v->i);
    case PyObject::Kind::kBigInt: return v->s;
    case PyObject::Kind::kFloat: return v->Repr();
    default: return v->Repr(1000);
  }
}

void Walk(const PyRef& v, const std::string& prefix, const PthFile& pth, std::vector<std::string>* names,
          std::map<std::string, TensorView>* tensors, std::map<std::string, std::string>* meta, int depth) {
  if (depth > 64) return;
  switch (v->kind) {
    case PyObject::Kind::kTensor:
      if (!tensors->count(prefix)) {
        names->push_back(prefix);
        (*tensors)[prefix] = pth.tensors[static_cast<size_t>(v->i)];
      }
      return;
    case PyObject::Kind::kDict:
      for (const auto& [k, x] : v->dict) Walk(x, Join(prefix, KeyString(k)), pth, names, tensors, meta, depth + 1);
      return;
    case PyObject::Kind::kList:
    case PyObject::Kind::kTuple: {
      bool all_scalar = true;
      for (const auto& x : v->items)
        if (x->is(PyObject::Kind::kTensor) || x->is(PyObject::Kind::kDict) || x->is(PyObject::Kind::kObject) ||
            x->is(PyObject::Kind::kList) || x->is(PyObject::Kind::kTuple))
          all_scalar = false;
      if (all_scalar) {
        (*meta)[prefix] = v->Repr(1000);
        return;
      }
      for (size_t k = 0; k < v->items.size(); ++k)
        Walk(v->items[k], Join(prefix, std::to_string(k)), pth, names, tensors, meta, depth + 1);
      return;
    }
    case PyObject::Kind::kObject:
      if (v->state) Walk(v->state, prefix, pth, names, tensors, meta, depth + 1);
      for (const auto& [k, x] : v->dict) Walk(x, Join(prefix, KeyString(k)), pth, names, tensors, meta, depth + 1);
      if (!v->state && v->dict.empty()) (*meta)[prefix] = v->Repr(1000);
      return;
    case PyObject::Kind::kBytes: (*meta)[prefix] = "<" + std::to_string(v->s.size()) + " bytes>"; return;
    default: (*meta)[prefix] = ScalarString(v); return;
  }
}

}  // namespace

// A safetensors file starts with its header's length (u64, little-endian) and the header's '{'; a length whose low
// byte is 0x80 must not be taken for a legacy pickle's PROTO opcode (about 1 valid file in 32 was refused).
bool LooksLikeSafetensors(const uint8_t* b, size_t size) {
  if (size < 10) return false;
  uint64_t n = 0;
  for (int i = 7; i >= 0; --i) n = (n << 8) | b[i];
  return n >= 2 && n <= size - 8 && b[8] == '{';
}

Checkpoint Checkpoint::Open(const std::string& path) {
  bool zip = false, pickle = false;
  {
    std::error_code ec;
    FREELOC_CHECK(std::filesystem::exists(path, ec), path << ": cannot open the checkpoint; check the path");
    const auto file = MappedFile::Open(path);  // a regular file, or an error (never blocks on a FIFO)
    const uint8_t* b = file->data();
    const size_t n = file->size();
    zip = n >= 2 && b[0] == 'P' && b[1] == 'K';
    pickle = !zip && n >= 2 && b[0] == 0x80 && !LooksLikeSafetensors(b, n);
  }
  Checkpoint c;
  c.path_ = path;
  if (zip || pickle) {
    PthFile pth = PthFile::Open(path);
    c.format_ = Format::kPth;
    c.root_ = pth.root;
    Walk(pth.root, "", pth, &c.names_, &c.tensors_, &c.metadata_, 0);
  } else {
    SafetensorsFile st = SafetensorsFile::Open(path);
    c.format_ = Format::kSafetensors;
    c.names_ = st.names;
    c.tensors_ = std::move(st.tensors);
    c.metadata_ = std::move(st.metadata);
  }
  return c;
}

const TensorView& Checkpoint::Get(const std::string& name) const {
  auto it = tensors_.find(name);
  FREELOC_CHECK(it != tensors_.end(), path_ << ": no tensor named '" << name << "' in the checkpoint");
  return it->second;
}

std::string Checkpoint::MetadataOr(const std::string& key, const std::string& fallback) const {
  auto it = metadata_.find(key);
  return it == metadata_.end() ? fallback : it->second;
}

std::string Checkpoint::StateDictRoot(const std::vector<std::string>& roots_in) const {
  static const std::vector<std::string> kDefault = {"model", "model_state_dict", "state_dict", "module"};
  const auto& roots = roots_in.empty() ? kDefault : roots_in;
  for (const auto& r : roots) {
    if (r.empty()) return r;
    const std::string p = r + ".";
    for (const auto& n : names_)
      if (n.compare(0, p.size(), p) == 0) return r;
  }
  return "";
}

std::map<std::string, TensorView> Checkpoint::StateDict(const std::vector<std::string>& roots) const {
  const std::string root = StateDictRoot(roots);
  std::map<std::string, TensorView> out;
  const std::string p = root.empty() ? "" : root + ".";
  for (const auto& n : names_) {
    if (n.compare(0, p.size(), p) == 0) out[n.substr(p.size())] = tensors_.at(n);
  }
  return out;
}

}  // namespace freeloc::io
