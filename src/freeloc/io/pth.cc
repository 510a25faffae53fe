#include "freeloc/io/pth.h"

#include <zip.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <memory>

#include "freeloc/core/checked_math.h"
#include "freeloc/core/error.h"
#include "freeloc/core/limits.h"
#include "freeloc/io/file_util.h"

namespace freeloc::io {

namespace {

struct ZipCloser {
  void operator()(zip_t* z) const {
    if (z) zip_discard(z);
  }
};

bool StorageDType(const std::string& cls, DType* d) {
  static const std::map<std::string, DType> kMap = {{"FloatStorage", DType::kF32}, {"DoubleStorage", DType::kF64},
                                                    {"HalfStorage", DType::kF16},  {"BFloat16Storage", DType::kBF16},
                                                    {"LongStorage", DType::kI64},  {"IntStorage", DType::kI32},
                                                    {"ShortStorage", DType::kI16}, {"CharStorage", DType::kI8},
                                                    {"ByteStorage", DType::kU8},   {"BoolStorage", DType::kBool}};
  auto it = kMap.find(cls);
  if (it == kMap.end()) return false;
  *d = it->second;
  return true;
}

struct Storage {
  DType dtype;
  int64_t numel = 0;
  std::shared_ptr<std::vector<uint8_t>> bytes;
};

std::vector<int64_t> IntTuple(const PyRef& t, const std::string& what, const char* field) {
  FREELOC_CHECK(t && (t->is(PyObject::Kind::kTuple) || t->is(PyObject::Kind::kList)),
                what << ": tensor " << field << " is not a tuple; the checkpoint is damaged");
  std::vector<int64_t> out;
  for (const auto& v : t->items) {
    FREELOC_CHECK(v->is(PyObject::Kind::kInt), what << ": tensor " << field << " holds a non-integer");
    out.push_back(v->i);
  }
  return out;
}

// Refuses what is not a zip-format torch.save checkpoint, naming the format it is instead.
void CheckMagic(const MappedFile& bytes, const std::string& path) {
  FREELOC_CHECK(bytes.size() >= 4, path << ": file of " << bytes.size() << " bytes is not a PyTorch checkpoint");
  const uint8_t* b = bytes.data();
  if (b[0] == 0x80 && b[1] <= 5) {
    FREELOC_THROW(
        path << ": legacy (non-zip) PyTorch checkpoint format, written by torch.save before PyTorch 1.6 or with "
                "_use_new_zipfile_serialization=False; freeloc reads only the zip format — re-save it with "
                "torch.save(torch.load(f), f) in a recent PyTorch");
  }
  FREELOC_CHECK(
      b[0] == 'P' && b[1] == 'K',
      path << ": not a PyTorch checkpoint (neither the zip format nor the legacy pickle format); check the file");
}

// The view (offset, size, stride) of a storage, checked to lie inside it; strided views are copied to contiguous.
TensorView StorageView(const Storage& st, int64_t offset, std::vector<int64_t> shape,
                       const std::vector<int64_t>& stride, const std::string& what, bool* contiguous) {
  TensorView t;
  t.dtype = st.dtype;
  t.shape = std::move(shape);
  FREELOC_CHECK(stride.size() == t.shape.size(), what << ": tensor size and stride differ in length");
  FREELOC_CHECK(offset >= 0 && offset <= st.numel, what << ": storage offset " << offset
                                                        << " lies outside its storage of " << st.numel
                                                        << " elements; the checkpoint is damaged");
  const int64_t numel = CheckedNumel(t.shape, what);
  // Extent check, overflow-safe: every addressed element must lie inside the storage.
  int64_t max_index = offset;
  *contiguous = true;
  int64_t expect = 1;
  for (size_t d = t.shape.size(); d-- > 0;) {
    FREELOC_CHECK(t.shape[d] >= 0 && stride[d] >= 0, what << ": negative size or stride");
    if (t.shape[d] > 1 && stride[d] != expect) *contiguous = false;
    expect = CheckedMul(expect, t.shape[d], what);
    if (t.shape[d] > 0) max_index = CheckedAdd(max_index, CheckedMul(t.shape[d] - 1, stride[d], what), what);
  }
  FREELOC_CHECK(numel == 0 || max_index < st.numel, what << ": tensor view (offset " << offset << ", size "
                                                         << t.ShapeString() << ") reaches past its storage of "
                                                         << st.numel << " elements; the checkpoint is damaged");
  const size_t es = DTypeSize(st.dtype);
  t.nbytes = static_cast<size_t>(CheckedMul(numel, static_cast<int64_t>(es), what));
  // A strided view is copied out. A transposed or sliced one addresses at most its storage's elements; one that
  // addresses more (stride 0: a broadcast) may expand a tiny record, so beyond its storage it is bounded by 64 MiB
  // (4 GiB from a 4-element storage once took minutes to copy).
  constexpr int64_t kMaxExpanded = int64_t{64} << 20;
  FREELOC_CHECK(*contiguous || numel <= st.numel || static_cast<int64_t>(t.nbytes) <= kMaxExpanded,
                what << ": tensor view " << t.ShapeString() << " would expand " << st.numel << " stored elements into "
                     << t.nbytes
                     << " bytes (limit: its storage's size, or 64 MiB); the checkpoint is damaged or "
                        "hostile");
  if (*contiguous) {
    t.data = st.bytes->data() + static_cast<size_t>(offset) * es;
    t.owner = st.bytes;
    return t;
  }
  auto buf = std::make_shared<std::vector<uint8_t>>(t.nbytes);
  std::vector<int64_t> idx(t.shape.size(), 0);
  for (int64_t e = 0; e < numel; ++e) {
    int64_t src = offset;
    for (size_t d = 0; d < idx.size(); ++d) src += idx[d] * stride[d];
    std::memcpy(buf->data() + e * es, st.bytes->data() + src * es, es);
    for (size_t d = idx.size(); d-- > 0;) {
      if (++idx[d] < t.shape[d]) break;
      idx[d] = 0;
    }
  }
  t.data = buf->data();
  t.owner = buf;
  return t;
}

PickleLimits PickleOptions() {
  PickleLimits l;
  l.max_objects = static_cast<size_t>(Limits().max_pickle_objects);
  return l;
}

// One checkpoint being read: the zip archive, its record prefix, the storages loaded so far and the tensors.
class PthReader {
 public:
  PthReader(const MappedFile& bytes, std::string path) : path_(std::move(path)) {
    zip_error_t zerr;
    zip_error_init(&zerr);
    zip_source_t* src = zip_source_buffer_create(bytes.data(), bytes.size(), 0, &zerr);
    FREELOC_CHECK(src != nullptr, path_ << ": cannot read as zip (" << zip_error_strerror(&zerr) << ")");
    z_.reset(zip_open_from_source(src, ZIP_RDONLY | ZIP_CHECKCONS, &zerr));
    if (!z_) {
      zip_source_free(src);
      const std::string msg = zip_error_strerror(&zerr);
      zip_error_fini(&zerr);
      FREELOC_THROW(path_ << ": damaged zip archive (" << msg << "); re-download the checkpoint");
    }
    zip_error_fini(&zerr);
    FindPrefix();
    pkl_name_ = path_ + "/" + prefix_ + "data.pkl";
  }

  PthFile Read() {
    std::vector<uint8_t> bo;
    if (ReadRecord(prefix_ + "byteorder", &bo)) {
      const std::string order(bo.begin(), bo.end());
      FREELOC_CHECK(order == "little", path_ << ": checkpoint byte order is '" << order
                                             << "'; only little-endian checkpoints are supported");
    }
    std::vector<uint8_t> pkl;
    ReadRecord(prefix_ + "data.pkl", &pkl);
    out_.path = path_;
    out_.root = ParsePickle(
        pkl.data(), pkl.size(), pkl_name_, [this](const PyRef& pid) { return LoadStorage(pid); },
        [this](const std::string& m, const std::string& name, const PyRef& args) { return Reduce(m, name, args); },
        PickleOptions());
    return std::move(out_);
  }

 private:
  // <archive>/data.pkl: exactly one top-level folder holds it.
  void FindPrefix() {
    const zip_int64_t n = zip_get_num_entries(z_.get(), 0);
    bool torchscript = false;
    for (zip_int64_t k = 0; k < n; ++k) {
      const char* name = zip_get_name(z_.get(), k, 0);
      if (!name) continue;
      const std::string s(name);
      const size_t slash = s.find('/');
      if (slash == std::string::npos) continue;
      const std::string rest = s.substr(slash + 1);
      if (rest == "data.pkl") {
        FREELOC_CHECK(prefix_.empty(), path_ << ": zip holds several data.pkl records; not a torch.save checkpoint");
        prefix_ = s.substr(0, slash + 1);
      }
      if (rest == "constants.pkl" || rest.rfind("code/", 0) == 0) torchscript = true;
    }
    if (!prefix_.empty()) return;
    FREELOC_CHECK(!torchscript, path_ << ": this is a TorchScript archive (torch.jit.save), not a state-dict "
                                         "checkpoint; use the released .pth checkpoint instead");
    FREELOC_THROW(path_ << ": zip archive without <name>/data.pkl; not a PyTorch checkpoint");
  }

  bool ReadRecord(const std::string& rec, std::vector<uint8_t>* out) {
    zip_stat_t st;
    zip_stat_init(&st);
    if (zip_stat(z_.get(), rec.c_str(), 0, &st) != 0) return false;
    CheckZipMemberSize(st.size, st.comp_size, st.comp_method == ZIP_CM_STORE, path_ + ": record '" + rec + "'");
    zip_file_t* f = zip_fopen(z_.get(), rec.c_str(), 0);
    FREELOC_CHECK(f != nullptr, path_ << ": cannot open record '" << rec << "' (" << zip_strerror(z_.get()) << ")");
    out->resize(static_cast<size_t>(st.size));
    const zip_int64_t got = st.size ? zip_fread(f, out->data(), st.size) : 0;
    zip_fclose(f);
    FREELOC_CHECK(got == static_cast<zip_int64_t>(st.size), path_ << ": record '" << rec << "' is truncated (" << got
                                                                  << " of " << st.size
                                                                  << " bytes); re-download the checkpoint");
    return true;
  }

  // Storage persistent ids: ('storage', <GLOBAL torch.XStorage>, key, location, numel).
  PyRef LoadStorage(const PyRef& pid) {
    FREELOC_CHECK(pid->is(PyObject::Kind::kTuple) && pid->items.size() >= 5 &&
                      pid->items[0]->is(PyObject::Kind::kStr) && pid->items[0]->s == "storage",
                  pkl_name_ << ": unexpected persistent id " << pid->Repr(200) << "; not a torch.save checkpoint");
    const PyRef& cls = pid->items[1];
    const PyRef& key = pid->items[2];
    const PyRef& numel = pid->items[4];
    FREELOC_CHECK(cls->is(PyObject::Kind::kGlobal) && key->is(PyObject::Kind::kStr) && numel->is(PyObject::Kind::kInt),
                  pkl_name_ << ": malformed storage record " << pid->Repr(200));
    Storage st;
    FREELOC_CHECK(StorageDType(cls->name, &st.dtype),
                  pkl_name_ << ": storage type " << cls->module << "." << cls->name
                            << " is not supported (Float, Double, Half, BFloat16, Long, Int, Short, Char, Byte, Bool)");
    st.numel = numel->i;
    if (!storages_.count(key->s)) {
      st.bytes = std::make_shared<std::vector<uint8_t>>();
      const std::string rec = prefix_ + "data/" + key->s;
      FREELOC_CHECK(ReadRecord(rec, st.bytes.get()), path_ << ": storage record '" << rec
                                                           << "' is missing from the archive; the checkpoint is "
                                                           << "incomplete or damaged — re-download it");
      // The declared element count against the record's real length, in checked arithmetic: a count whose byte
      // size wraps 64 bits must not match a tiny record (every view is bounded by this count afterwards).
      FREELOC_CHECK(st.numel >= 0, path_ << ": storage record '" << rec << "' declares " << st.numel
                                         << " elements; the checkpoint is damaged");
      const int64_t need = CheckedMul(st.numel, static_cast<int64_t>(DTypeSize(st.dtype)),
                                      path_ + ": storage record '" + rec + "' size");
      FREELOC_CHECK(st.bytes->size() >= static_cast<uint64_t>(need),
                    path_ << ": storage record '" << rec << "' holds " << st.bytes->size() << " bytes, but " << st.numel
                          << " elements of " << DTypeName(st.dtype) << " need " << need
                          << "; re-download the checkpoint");
      storages_.emplace(key->s, st);
    } else {
      const Storage& seen = storages_.at(key->s);
      FREELOC_CHECK(seen.dtype == st.dtype && seen.numel == st.numel,
                    pkl_name_ << ": storage '" << key->s << "' is declared twice with different types or sizes; the "
                              << "checkpoint is damaged");
    }
    auto o = std::make_shared<PyObject>();
    o->kind = PyObject::Kind::kObject;
    o->module = "freeloc";
    o->name = "storage";
    o->s = key->s;
    return o;
  }

  // torch._utils._rebuild_tensor(_v2) → a tensor of `out_`; _rebuild_parameter → its tensor.
  PyRef Reduce(const std::string& m, const std::string& name, const PyRef& args) {
    if (m == "torch._utils" && (name == "_rebuild_tensor_v2" || name == "_rebuild_tensor")) {
      FREELOC_CHECK(args && args->items.size() >= 4, pkl_name_ << ": " << name << " with too few arguments");
      const PyRef& sref = args->items[0];
      FREELOC_CHECK(sref->is(PyObject::Kind::kObject) && sref->module == "freeloc" && sref->name == "storage",
                    pkl_name_ << ": tensor without a storage; not a torch.save checkpoint");
      FREELOC_CHECK(args->items[1]->is(PyObject::Kind::kInt), pkl_name_ << ": tensor storage offset is not an int");
      FREELOC_CHECK(static_cast<int64_t>(out_.tensors.size()) < Limits().max_tensors,
                    pkl_name_ << ": more than " << Limits().max_tensors << " tensors; refused ("
                              << LimitHint("max_tensors") << ")");
      bool contiguous = true;
      TensorView t = StorageView(storages_.at(sref->s), args->items[1]->i, IntTuple(args->items[2], pkl_name_, "size"),
                                 IntTuple(args->items[3], pkl_name_, "stride"), pkl_name_, &contiguous);
      auto o = std::make_shared<PyObject>();
      o->kind = PyObject::Kind::kTensor;
      o->i = static_cast<int64_t>(out_.tensors.size());
      out_.tensors.push_back(std::move(t));
      out_.was_contiguous.push_back(contiguous);
      return o;
    }
    if (m == "torch._utils" && (name == "_rebuild_parameter" || name == "_rebuild_parameter_with_state")) {
      FREELOC_CHECK(args && !args->items.empty() && args->items[0]->is(PyObject::Kind::kTensor),
                    pkl_name_ << ": parameter without a tensor");
      return args->items[0];
    }
    return nullptr;
  }

  std::string path_, prefix_, pkl_name_;
  std::unique_ptr<zip_t, ZipCloser> z_;
  std::map<std::string, Storage> storages_;
  PthFile out_;
};

}  // namespace

PthFile PthFile::Open(const std::string& path) {
  const auto bytes = MappedFile::Open(path);
  CheckMagic(*bytes, path);
  return PthReader(*bytes, path).Read();
}

}  // namespace freeloc::io
