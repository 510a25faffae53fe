// A safe subset of Python's pickle format, enough for PyTorch checkpoints (torch.save protocols 2–5):
// dicts/OrderedDicts, lists, tuples, ints (incl. big), floats, str, bytes, bools, None, globals, objects of
// unknown classes kept opaque (class name, constructor args, BUILD state), and persistent ids (torch storages).
// Nothing is ever executed; an opcode outside the subset is a freeloc::Error that names it.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace freeloc::io {

struct PyObject;
using PyRef = std::shared_ptr<PyObject>;

struct PyObject {
  enum class Kind {
    kNone,
    kBool,
    kInt,
    kBigInt,
    kFloat,
    kStr,
    kBytes,
    kList,
    kTuple,
    kDict,
    kSet,
    kGlobal,
    kObject,
    kTensor
  };
  Kind kind = Kind::kNone;
  bool b = false;
  int64_t i = 0;                              // kInt; kTensor: index into the caller's tensor table
  double f = 0;                               // kFloat
  std::string s;                              // kStr, kBytes, kBigInt (decimal digits with sign)
  std::vector<PyRef> items;                   // kList, kTuple, kSet
  std::vector<std::pair<PyRef, PyRef>> dict;  // kDict (insertion order), and kObject's dict items
  std::string module, name;                   // kGlobal, kObject (its class)
  PyRef args;                                 // kObject: constructor/reduce arguments (a tuple)
  PyRef state;                                // kObject (and dicts given a BUILD state): the state

  PyObject() = default;
  PyObject(const PyObject&) = delete;
  PyObject& operator=(const PyObject&) = delete;
  // Tears nested children down with an explicit work list, never by recursion: a pickle nested 200 000 deep must
  // not overflow the stack when it is freed.
  ~PyObject();

  static PyRef None();
  static PyRef Bool(bool v);
  static PyRef Int(int64_t v);
  static PyRef Float(double v);
  static PyRef Str(std::string v);

  bool is(Kind k) const { return kind == k; }
  // Dict lookup by string key (also an object's state dict); nullptr when absent.
  PyRef Get(const std::string& key) const;
  // Dotted path lookup through dicts, object state and list/tuple indices ("nested.list.2", "args.model").
  PyRef Find(const std::string& dotted) const;
  // Python-like repr for printing ("'abc'", "[1, 2.5]", "argparse.Namespace(lr=0.1, …)").
  std::string Repr(size_t max_len = 2000) const;
  std::string KindName() const;
};

// Persistent-id loader: receives the BINPERSID payload (for torch, a tuple ('storage', cls, key, location, numel))
// and returns the object to push.
using PersistentLoad = std::function<PyRef(const PyRef& pid)>;
// Reducer hook: called for REDUCE/NEWOBJ on a global before the generic opaque-object fallback; returns nullptr
// to decline.
using ReduceHook = std::function<PyRef(const std::string& module, const std::string& name, const PyRef& args)>;

// What a pickle may cost. The defaults are far beyond any real checkpoint (a DUSt3R state dict is about
// 10 000 objects, nested 6 deep); every limit hit is a one-line error naming the stream.
struct PickleLimits {
  size_t max_objects = 2'000'000;    // values pushed, also the stack and memo sizes (~250 bytes each)
  size_t max_depth = 1000;           // container nesting
  size_t max_expanded = 20'000'000;  // objects seen by a walk that follows every shared reference (DAG bombs)
  size_t max_long_bytes = 1024;      // LONG1/LONG4 integers (Python itself caps int→str at 4300 digits)
};

// The classes a checkpoint may name by GLOBAL/STACK_GLOBAL (torch's tensor rebuilders and storage types, dtypes,
// OrderedDict, argparse.Namespace, builtin containers, numpy scalars and arrays, pathlib paths); anything else is
// refused with a message naming it. Nothing is ever called or imported either way.
bool IsAllowedPickleGlobal(const std::string& module, const std::string& name);

// Parses a pickle stream. `what` names the source in errors ("model.pth/archive/data.pkl").
PyRef ParsePickle(const uint8_t* data, size_t size, const std::string& what, const PersistentLoad& persistent_load,
                  const ReduceHook& reduce_hook = nullptr, const PickleLimits& limits = PickleLimits());

}  // namespace freeloc::io
