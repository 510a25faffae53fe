// Builds zip-format torch.save checkpoints whose tensor metadata is chosen freely — the storage's class, its
// declared element count, the bytes its record really holds, and each tensor's offset, size and stride — written
// with the pickle opcodes torch uses (protocol 2, BINPERSID storages, _rebuild_tensor_v2). For the hostile-input
// tests and the structure-aware fuzz target (fuzz/pth_structured.cc): byte-level mutation almost never produces a
// well-formed checkpoint whose metadata lies; this does so on purpose. Header-only; needs freeloc::io.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "freeloc/io/submission.h"

namespace freeloc::testing {

struct PthTensorSpec {
  std::string name = "w";
  std::string storage_key = "0";  // several tensors may share a storage (views)
  int64_t offset = 0;
  std::vector<int64_t> shape, stride;
};

struct PthStorageSpec {
  std::string key = "0";
  std::string cls = "FloatStorage";  // torch.<cls>
  int64_t declared_numel = 0;        // what the pickle says
  uint64_t record_bytes = 0;         // what the archive's data/<key> record holds
};

struct PthSpec {
  std::vector<PthStorageSpec> storages;
  std::vector<PthTensorSpec> tensors;
};

namespace pth_detail {

inline std::string Le(uint64_t v, int n) {
  std::string s;
  for (int i = 0; i < n; ++i) s += static_cast<char>((v >> (8 * i)) & 0xff);
  return s;
}
inline std::string Str(const std::string& s) { return "X" + Le(s.size(), 4) + s; }           // BINUNICODE
inline std::string Long(int64_t v) { return "\x8a\x08" + Le(static_cast<uint64_t>(v), 8); }  // LONG1, 8 bytes
inline std::string Ints(const std::vector<int64_t>& v) {
  std::string t = "(";
  for (int64_t x : v) t += Long(x);
  return t + "t";
}

}  // namespace pth_detail

// The pickle (data.pkl) of a state dict {name: tensor}; a tensor naming a storage the spec lacks gets one declared
// with 0 elements.
inline std::string PthPickle(const PthSpec& spec) {
  using namespace pth_detail;
  std::map<std::string, const PthStorageSpec*> by_key;
  for (const auto& s : spec.storages) by_key[s.key] = &s;
  std::string p = std::string("\x80\x02") + "}(";  // EMPTY_DICT, MARK
  for (const auto& t : spec.tensors) {
    const auto it = by_key.find(t.storage_key);
    const std::string cls = it != by_key.end() ? it->second->cls : "FloatStorage";
    const int64_t numel = it != by_key.end() ? it->second->declared_numel : 0;
    p += Str(t.name);
    p += "ctorch._utils\n_rebuild_tensor_v2\n";
    p += "((" + Str("storage") + "ctorch\n" + cls + "\n" + Str(t.storage_key) + Str("cpu") + Long(numel) + "tQ";
    p += Long(t.offset) + Ints(t.shape) + Ints(t.stride);
    p += "\x89";                           // NEWFALSE: requires_grad
    p += "ccollections\nOrderedDict\n)R";  // backward hooks
    p += "tR";
  }
  p += "u.";  // SETITEMS, STOP
  return p;
}

// The archive's members: data.pkl, byteorder and one record per storage of `record_bytes` bytes (a ramp, so values
// read through a wrong view differ from the right ones).
inline std::map<std::string, std::string> PthMembers(const PthSpec& spec) {
  std::map<std::string, std::string> m = {{"archive/data.pkl", PthPickle(spec)}, {"archive/byteorder", "little"}};
  for (const auto& s : spec.storages) {
    std::string bytes(s.record_bytes, '\0');
    for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<char>(i * 7 + 1);
    m["archive/data/" + s.key] = bytes;
  }
  return m;
}

inline void WritePthSpec(const std::string& path, const PthSpec& spec) { io::WriteZipAtomic(path, PthMembers(spec)); }

// A float32 tensor of a real checkpoint: its name in the state dict, its shape and its values (row-major).
struct PthFloatTensor {
  std::string name;
  std::vector<int64_t> shape;
  std::vector<float> values;
};

// A checkpoint laid out as training code saves it — torch.save({'model': state_dict, 'args': Namespace(...)}) —
// with real values: one FloatStorage per tensor, contiguous, and the Namespace's string fields (DUSt3R and MASt3R
// read their constructor string from args.model). For checkpoints the tests write themselves.
inline std::string StateDictPickle(const std::vector<PthFloatTensor>& tensors,
                                   const std::map<std::string, std::string>& args) {
  using namespace pth_detail;
  std::string p = std::string("\x80\x02") + "}(";        // EMPTY_DICT, MARK
  p += Str("model") + "ccollections\nOrderedDict\n)R(";  // OrderedDict(), MARK
  for (size_t k = 0; k < tensors.size(); ++k) {
    const PthFloatTensor& t = tensors[k];
    std::vector<int64_t> stride(t.shape.size(), 1);
    for (size_t d = t.shape.size(); d-- > 1;) stride[d - 1] = stride[d] * t.shape[d];
    p += Str(t.name);
    p += "ctorch._utils\n_rebuild_tensor_v2\n";
    p += "((" + Str("storage") + "ctorch\nFloatStorage\n" + Str(std::to_string(k)) + Str("cpu") +
         Long(static_cast<int64_t>(t.values.size())) + "tQ";
    p += Long(0) + Ints(t.shape) + Ints(stride);
    p += "\x89";
    p += "ccollections\nOrderedDict\n)R";
    p += "tR";
  }
  p += "u";                                            // SETITEMS into the OrderedDict
  p += Str("args") + "cargparse\nNamespace\n)\x81}(";  // Namespace() by NEWOBJ, its state dict, MARK
  for (const auto& [key, value] : args) p += Str(key) + Str(value);
  p += "ub";  // SETITEMS, BUILD
  p += "u.";  // SETITEMS into the top dict, STOP
  return p;
}

inline void WriteStateDictPth(const std::string& path, const std::vector<PthFloatTensor>& tensors,
                              const std::map<std::string, std::string>& args) {
  std::map<std::string, std::string> m = {{"archive/data.pkl", StateDictPickle(tensors, args)},
                                          {"archive/byteorder", "little"}};
  for (size_t k = 0; k < tensors.size(); ++k) {
    const auto& v = tensors[k].values;
    m["archive/data/" + std::to_string(k)] =
        std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(float));
  }
  io::WriteZipAtomic(path, m);
}

}  // namespace freeloc::testing
