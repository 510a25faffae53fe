#include "freeloc/io/pth.h"

#include <zip.h>

#include <cstring>
#include <map>
#include <memory>

#include "freeloc/core/error.h"
#include "freeloc/io/file_util.h"

namespace freeloc {

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

}  // namespace

PthFile PthFile::Open(const std::string& path) {
  const auto bytes = MappedFile::Open(path);
  FREELOC_CHECK(bytes->size() >= 4, path << ": file of " << bytes->size() << " bytes is not a PyTorch checkpoint");
  const uint8_t* b = bytes->data();
  if (b[0] == 0x80 && b[1] <= 5 && !(b[0] == 'P' && b[1] == 'K')) {
    FREELOC_THROW(
        path << ": legacy (non-zip) PyTorch checkpoint format, written by torch.save before PyTorch 1.6 or with "
                "_use_new_zipfile_serialization=False; freeloc reads only the zip format — re-save it with "
                "torch.save(torch.load(f), f) in a recent PyTorch");
  }
  FREELOC_CHECK(
      b[0] == 'P' && b[1] == 'K',
      path << ": not a PyTorch checkpoint (neither the zip format nor the legacy pickle format); check the file");

  zip_error_t zerr;
  zip_error_init(&zerr);
  zip_source_t* src = zip_source_buffer_create(bytes->data(), bytes->size(), 0, &zerr);
  FREELOC_CHECK(src != nullptr, path << ": cannot read as zip (" << zip_error_strerror(&zerr) << ")");
  std::unique_ptr<zip_t, ZipCloser> z(zip_open_from_source(src, ZIP_RDONLY | ZIP_CHECKCONS, &zerr));
  if (!z) {
    zip_source_free(src);
    const std::string msg = zip_error_strerror(&zerr);
    zip_error_fini(&zerr);
    FREELOC_THROW(path << ": damaged zip archive (" << msg << "); re-download the checkpoint");
  }
  zip_error_fini(&zerr);

  // Locate <archive>/data.pkl (exactly one top-level folder holds it).
  const zip_int64_t n = zip_get_num_entries(z.get(), 0);
  std::string prefix;
  bool torchscript = false;
  for (zip_int64_t k = 0; k < n; ++k) {
    const char* name = zip_get_name(z.get(), k, 0);
    if (!name) continue;
    const std::string s(name);
    const size_t slash = s.find('/');
    if (slash == std::string::npos) continue;
    const std::string rest = s.substr(slash + 1);
    if (rest == "data.pkl") {
      FREELOC_CHECK(prefix.empty(), path << ": zip holds several data.pkl records; not a torch.save checkpoint");
      prefix = s.substr(0, slash + 1);
    }
    if (rest == "constants.pkl" || rest.rfind("code/", 0) == 0) torchscript = true;
  }
  if (prefix.empty()) {
    FREELOC_CHECK(!torchscript,
                  path << ": this is a TorchScript archive (torch.jit.save), not a state-dict checkpoint; "
                          "use the released .pth checkpoint instead");
    FREELOC_THROW(path << ": zip archive without <name>/data.pkl; not a PyTorch checkpoint");
  }

  auto read_record = [&](const std::string& rec, std::vector<uint8_t>* out) -> bool {
    zip_stat_t st;
    zip_stat_init(&st);
    if (zip_stat(z.get(), rec.c_str(), 0, &st) != 0) return false;
    zip_file_t* f = zip_fopen(z.get(), rec.c_str(), 0);
    FREELOC_CHECK(f != nullptr, path << ": cannot open record '" << rec << "' (" << zip_strerror(z.get()) << ")");
    out->resize(static_cast<size_t>(st.size));
    const zip_int64_t got = st.size ? zip_fread(f, out->data(), st.size) : 0;
    zip_fclose(f);
    FREELOC_CHECK(got == static_cast<zip_int64_t>(st.size), path << ": record '" << rec << "' is truncated (" << got
                                                                 << " of " << st.size
                                                                 << " bytes); re-download the checkpoint");
    return true;
  };

  std::vector<uint8_t> bo;
  if (read_record(prefix + "byteorder", &bo)) {
    const std::string order(bo.begin(), bo.end());
    FREELOC_CHECK(order == "little",
                  path << ": checkpoint byte order is '" << order << "'; only little-endian checkpoints are supported");
  }

  std::vector<uint8_t> pkl;
  read_record(prefix + "data.pkl", &pkl);
  const std::string pkl_name = path + "/" + prefix + "data.pkl";

  PthFile out;
  out.path = path;
  std::map<std::string, Storage> storages;

  // Storage persistent ids: ('storage', <GLOBAL torch.XStorage>, key, location, numel).
  PersistentLoad persistent_load = [&](const PyRef& pid) -> PyRef {
    FREELOC_CHECK(pid->is(PyObject::Kind::kTuple) && pid->items.size() >= 5 &&
                      pid->items[0]->is(PyObject::Kind::kStr) && pid->items[0]->s == "storage",
                  pkl_name << ": unexpected persistent id " << pid->Repr(200) << "; not a torch.save checkpoint");
    const PyRef& cls = pid->items[1];
    const PyRef& key = pid->items[2];
    const PyRef& numel = pid->items[4];
    FREELOC_CHECK(cls->is(PyObject::Kind::kGlobal) && key->is(PyObject::Kind::kStr) && numel->is(PyObject::Kind::kInt),
                  pkl_name << ": malformed storage record " << pid->Repr(200));
    Storage st;
    FREELOC_CHECK(StorageDType(cls->name, &st.dtype),
                  pkl_name << ": storage type " << cls->module << "." << cls->name
                           << " is not supported (Float, Double, Half, BFloat16, Long, Int, Short, Char, Byte, Bool)");
    st.numel = numel->i;
    auto it = storages.find(key->s);
    if (it == storages.end()) {
      st.bytes = std::make_shared<std::vector<uint8_t>>();
      const std::string rec = prefix + "data/" + key->s;
      FREELOC_CHECK(read_record(rec, st.bytes.get()), path << ": storage record '" << rec
                                                           << "' is missing from the archive; the checkpoint is "
                                                           << "incomplete or damaged — re-download it");
      FREELOC_CHECK(st.bytes->size() >= static_cast<size_t>(st.numel) * DTypeSize(st.dtype),
                    path << ": storage record '" << rec << "' holds " << st.bytes->size() << " bytes, but " << st.numel
                         << " elements of " << DTypeName(st.dtype) << " need " << st.numel * DTypeSize(st.dtype)
                         << "; re-download the checkpoint");
      it = storages.emplace(key->s, st).first;
    }
    auto o = std::make_shared<PyObject>();
    o->kind = PyObject::Kind::kObject;
    o->module = "freeloc";
    o->name = "storage";
    o->s = key->s;
    return o;
  };

  ReduceHook reduce = [&](const std::string& m, const std::string& name, const PyRef& args) -> PyRef {
    if (m == "torch._utils" && (name == "_rebuild_tensor_v2" || name == "_rebuild_tensor")) {
      FREELOC_CHECK(args && args->items.size() >= 4, pkl_name << ": " << name << " with too few arguments");
      const PyRef& sref = args->items[0];
      FREELOC_CHECK(sref->is(PyObject::Kind::kObject) && sref->module == "freeloc" && sref->name == "storage",
                    pkl_name << ": tensor without a storage; not a torch.save checkpoint");
      const Storage& st = storages.at(sref->s);
      FREELOC_CHECK(args->items[1]->is(PyObject::Kind::kInt), pkl_name << ": tensor storage offset is not an int");
      const int64_t offset = args->items[1]->i;
      TensorView t;
      t.dtype = st.dtype;
      t.shape = IntTuple(args->items[2], pkl_name, "size");
      const std::vector<int64_t> stride = IntTuple(args->items[3], pkl_name, "stride");
      FREELOC_CHECK(stride.size() == t.shape.size(), pkl_name << ": tensor size and stride differ in length");
      const int64_t numel = t.numel();
      // Extent check: every addressed element must lie inside the storage.
      int64_t max_index = offset;
      bool contiguous = true;
      int64_t expect = 1;
      for (size_t d = t.shape.size(); d-- > 0;) {
        FREELOC_CHECK(t.shape[d] >= 0 && stride[d] >= 0, pkl_name << ": negative size or stride");
        if (t.shape[d] > 1 && stride[d] != expect) contiguous = false;
        expect *= t.shape[d];
        if (t.shape[d] > 0) max_index += (t.shape[d] - 1) * stride[d];
      }
      FREELOC_CHECK(offset >= 0 && (numel == 0 || max_index < st.numel),
                    pkl_name << ": tensor view (offset " << offset << ", size " << t.ShapeString()
                             << ") reaches past its storage of " << st.numel << " elements; the checkpoint is damaged");
      const size_t es = DTypeSize(st.dtype);
      t.nbytes = static_cast<size_t>(numel) * es;
      if (contiguous) {
        t.data = st.bytes->data() + static_cast<size_t>(offset) * es;
        t.owner = st.bytes;
      } else {
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
      }
      auto o = std::make_shared<PyObject>();
      o->kind = PyObject::Kind::kTensor;
      o->i = static_cast<int64_t>(out.tensors.size());
      out.tensors.push_back(std::move(t));
      out.was_contiguous.push_back(contiguous);
      return o;
    }
    if (m == "torch._utils" && (name == "_rebuild_parameter" || name == "_rebuild_parameter_with_state")) {
      FREELOC_CHECK(args && !args->items.empty() && args->items[0]->is(PyObject::Kind::kTensor),
                    pkl_name << ": parameter without a tensor");
      return args->items[0];
    }
    return nullptr;
  };

  out.root = ParsePickle(pkl.data(), pkl.size(), pkl_name, persistent_load, reduce);
  return out;
}

}  // namespace freeloc
