#include "freeloc/io/pickle.h"

#include <cstring>
#include <set>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include "freeloc/core/error.h"

namespace freeloc::io {

namespace {
// Moves the children of `o` onto `pending` so that `o` itself is freed without recursion.
void DetachChildren(PyObject& o, std::vector<PyRef>* pending) {
  for (auto& c : o.items) pending->push_back(std::move(c));
  for (auto& [k, v] : o.dict) {
    pending->push_back(std::move(k));
    pending->push_back(std::move(v));
  }
  if (o.args) pending->push_back(std::move(o.args));
  if (o.state) pending->push_back(std::move(o.state));
  o.items.clear();
  o.dict.clear();
}
}  // namespace

PyObject::~PyObject() {
  if (items.empty() && dict.empty() && !args && !state) return;
  std::vector<PyRef> pending;
  DetachChildren(*this, &pending);
  while (!pending.empty()) {
    PyRef p = std::move(pending.back());
    pending.pop_back();
    if (p && p.use_count() == 1) DetachChildren(*p, &pending);  // the last owner: take its children first
  }
}

bool IsAllowedPickleGlobal(const std::string& module, const std::string& name) {
  static const std::set<std::pair<std::string, std::string>> kAllowed = {
      {"collections", "OrderedDict"},
      {"argparse", "Namespace"},
      {"_codecs", "encode"},
      {"copyreg", "_reconstructor"},
      {"torch._utils", "_rebuild_tensor"},
      {"torch._utils", "_rebuild_tensor_v2"},
      {"torch._utils", "_rebuild_parameter"},
      {"torch._utils", "_rebuild_parameter_with_state"},
      {"torch._tensor", "_rebuild_from_type_v2"},
      {"torch.nn.parameter", "Parameter"},
      {"torch", "Tensor"},
      {"torch", "Size"},
      {"torch", "device"},
      {"torch.storage", "UntypedStorage"},
      {"torch.storage", "TypedStorage"},
      {"numpy", "dtype"},
      {"numpy", "ndarray"},
      {"numpy.core.multiarray", "scalar"},
      {"numpy.core.multiarray", "_reconstruct"},
      {"numpy._core.multiarray", "scalar"},
      {"numpy._core.multiarray", "_reconstruct"},
      {"pathlib", "Path"},
      {"pathlib", "PosixPath"},
      {"pathlib", "PurePosixPath"},
      {"pathlib", "WindowsPath"},
      {"pathlib", "PureWindowsPath"},
  };
  static const std::set<std::string> kBuiltins = {"set",   "frozenset", "list",    "tuple", "dict",
                                                  "slice", "int",       "float",   "bool",  "str",
                                                  "bytes", "bytearray", "complex", "object"};
  static const std::set<std::string> kTorchTypes = {"FloatStorage",
                                                    "DoubleStorage",
                                                    "HalfStorage",
                                                    "BFloat16Storage",
                                                    "LongStorage",
                                                    "IntStorage",
                                                    "ShortStorage",
                                                    "CharStorage",
                                                    "ByteStorage",
                                                    "BoolStorage",
                                                    "float32",
                                                    "float64",
                                                    "float16",
                                                    "bfloat16",
                                                    "int64",
                                                    "int32",
                                                    "int16",
                                                    "int8",
                                                    "uint8",
                                                    "bool",
                                                    "float",
                                                    "double",
                                                    "half",
                                                    "long",
                                                    "int",
                                                    "short",
                                                    "contiguous_format",
                                                    "channels_last",
                                                    "preserve_format",
                                                    "strided"};
  if (kAllowed.count({module, name})) return true;
  if (module == "builtins" || module == "__builtin__") return kBuiltins.count(name) > 0;
  if (module == "torch") return kTorchTypes.count(name) > 0;
  if (module == "numpy.dtypes") return name.size() > 5 && name.compare(name.size() - 5, 5, "DType") == 0;
  return false;
}

PyRef PyObject::None() { return std::make_shared<PyObject>(); }
PyRef PyObject::Bool(bool v) {
  auto o = std::make_shared<PyObject>();
  o->kind = Kind::kBool;
  o->b = v;
  return o;
}
PyRef PyObject::Int(int64_t v) {
  auto o = std::make_shared<PyObject>();
  o->kind = Kind::kInt;
  o->i = v;
  return o;
}
PyRef PyObject::Float(double v) {
  auto o = std::make_shared<PyObject>();
  o->kind = Kind::kFloat;
  o->f = v;
  return o;
}
PyRef PyObject::Str(std::string v) {
  auto o = std::make_shared<PyObject>();
  o->kind = Kind::kStr;
  o->s = std::move(v);
  return o;
}

std::string PyObject::KindName() const {
  switch (kind) {
    case Kind::kNone: return "None";
    case Kind::kBool: return "bool";
    case Kind::kInt:
    case Kind::kBigInt: return "int";
    case Kind::kFloat: return "float";
    case Kind::kStr: return "str";
    case Kind::kBytes: return "bytes";
    case Kind::kList: return "list";
    case Kind::kTuple: return "tuple";
    case Kind::kDict: return "dict";
    case Kind::kSet: return "set";
    case Kind::kGlobal: return "global " + module + "." + name;
    case Kind::kObject: return module + "." + name;
    case Kind::kTensor: return "tensor";
  }
  return "?";
}

PyRef PyObject::Get(const std::string& key) const {
  const std::vector<std::pair<PyRef, PyRef>>* d = nullptr;
  if (kind == Kind::kDict) d = &dict;
  if (kind == Kind::kObject) {
    if (state && state->kind == Kind::kDict) {
      for (const auto& [k, v] : state->dict)
        if (k->kind == Kind::kStr && k->s == key) return v;
    }
    d = &dict;
  }
  if (!d) return nullptr;
  for (const auto& [k, v] : *d)
    if (k->kind == Kind::kStr && k->s == key) return v;
  return nullptr;
}

PyRef PyObject::Find(const std::string& dotted) const {
  // Keys may themselves contain dots (state_dict names); try the longest key prefix first.
  if (kind == Kind::kDict || kind == Kind::kObject) {
    std::vector<size_t> ends = {dotted.size()};
    for (size_t k = dotted.size(); k-- > 0;)
      if (dotted[k] == '.') ends.push_back(k);
    for (size_t end : ends) {
      PyRef v = Get(dotted.substr(0, end));
      if (!v) continue;
      if (end == dotted.size()) return v;
      PyRef r = v->Find(dotted.substr(end + 1));
      if (r) return r;
    }
    return nullptr;
  }
  if (kind == Kind::kList || kind == Kind::kTuple) {
    const size_t dot = dotted.find('.');
    const std::string head = dotted.substr(0, dot);
    char* endp = nullptr;
    const long idx = std::strtol(head.c_str(), &endp, 10);
    if (head.empty() || *endp != '\0' || idx < 0 || static_cast<size_t>(idx) >= items.size()) return nullptr;
    if (dot == std::string::npos) return items[idx];
    return items[idx]->Find(dotted.substr(dot + 1));
  }
  return nullptr;
}

namespace {
std::string ReprString(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'' || c == '\\') out += '\\';
    out += c;
  }
  return out + "'";
}
}  // namespace

namespace {

std::string FloatRepr(double f) {
  // Shortest text that reads back to the same double, like Python's repr.
  std::string t;
  for (int prec = 1; prec <= 17; ++prec) {
    std::ostringstream os;
    os.precision(prec);
    os << f;
    t = os.str();
    if (std::strtod(t.c_str(), nullptr) == f) break;
  }
  if (t.find_first_of(".einn") == std::string::npos) t += ".0";
  return t;
}

// Appends the repr of `o` to `out`, stopping as soon as `out` is longer than `budget` (a shared-reference bomb
// never makes the walk or the text large).
void ReprInto(const PyObject& o, std::string* out, size_t budget) {
  using Kind = PyObject::Kind;
  if (out->size() > budget) return;
  switch (o.kind) {
    case Kind::kNone: *out += "None"; return;
    case Kind::kBool: *out += o.b ? "True" : "False"; return;
    case Kind::kInt: *out += std::to_string(o.i); return;
    case Kind::kBigInt: *out += o.s; return;
    case Kind::kFloat: *out += FloatRepr(o.f); return;
    case Kind::kStr: *out += ReprString(o.s.size() > budget ? o.s.substr(0, budget + 1) : o.s); return;
    case Kind::kBytes: *out += "b<" + std::to_string(o.s.size()) + " bytes>"; return;
    case Kind::kList:
    case Kind::kTuple:
    case Kind::kSet: {
      *out += o.kind == Kind::kList ? "[" : o.kind == Kind::kTuple ? "(" : "{";
      for (size_t k = 0; k < o.items.size() && out->size() <= budget; ++k) {
        if (k) *out += ", ";
        ReprInto(*o.items[k], out, budget);
      }
      if (o.kind == Kind::kTuple && o.items.size() == 1) *out += ",";
      *out += o.kind == Kind::kList ? "]" : o.kind == Kind::kTuple ? ")" : "}";
      return;
    }
    case Kind::kDict: {
      *out += "{";
      for (size_t k = 0; k < o.dict.size() && out->size() <= budget; ++k) {
        if (k) *out += ", ";
        ReprInto(*o.dict[k].first, out, budget);
        *out += ": ";
        ReprInto(*o.dict[k].second, out, budget);
      }
      *out += "}";
      return;
    }
    case Kind::kGlobal: *out += o.module + "." + o.name; return;
    case Kind::kObject: {
      *out += o.module + "." + o.name + "(";
      bool first = true;
      if (o.state && o.state->kind == Kind::kDict) {
        for (const auto& [k, v] : o.state->dict) {
          if (out->size() > budget) break;
          if (!first) *out += ", ";
          if (k->kind == Kind::kStr) {
            *out += k->s;
          } else {
            ReprInto(*k, out, budget);
          }
          *out += "=";
          ReprInto(*v, out, budget);
          first = false;
        }
      } else if (o.args && !o.args->items.empty()) {
        for (const auto& a : o.args->items) {
          if (out->size() > budget) break;
          if (!first) *out += ", ";
          ReprInto(*a, out, budget);
          first = false;
        }
      }
      *out += ")";
      return;
    }
    case Kind::kTensor: *out += "<tensor #" + std::to_string(o.i) + ">"; return;
  }
}

}  // namespace

std::string PyObject::Repr(size_t max_len) const {
  std::string r;
  ReprInto(*this, &r, max_len);
  if (r.size() > max_len) r = r.substr(0, max_len) + "…";
  return r;
}

namespace {

const char* OpcodeName(uint8_t op) {
  switch (op) {
    case '(': return "MARK";
    case '.': return "STOP";
    case '0': return "POP";
    case '1': return "POP_MARK";
    case '2': return "DUP";
    case 'F': return "FLOAT";
    case 'I': return "INT";
    case 'J': return "BININT";
    case 'K': return "BININT1";
    case 'L': return "LONG";
    case 'M': return "BININT2";
    case 'N': return "NONE";
    case 'P': return "PERSID";
    case 'Q': return "BINPERSID";
    case 'R': return "REDUCE";
    case 'S': return "STRING";
    case 'T': return "BINSTRING";
    case 'U': return "SHORT_BINSTRING";
    case 'V': return "UNICODE";
    case 'X': return "BINUNICODE";
    case 'a': return "APPEND";
    case 'b': return "BUILD";
    case 'c': return "GLOBAL";
    case 'd': return "DICT";
    case '}': return "EMPTY_DICT";
    case 'e': return "APPENDS";
    case 'g': return "GET";
    case 'h': return "BINGET";
    case 'i': return "INST";
    case 'j': return "LONG_BINGET";
    case 'l': return "LIST";
    case ']': return "EMPTY_LIST";
    case 'o': return "OBJ";
    case 'p': return "PUT";
    case 'q': return "BINPUT";
    case 'r': return "LONG_BINPUT";
    case 's': return "SETITEM";
    case 't': return "TUPLE";
    case ')': return "EMPTY_TUPLE";
    case 'u': return "SETITEMS";
    case 'G': return "BINFLOAT";
    case 0x80: return "PROTO";
    case 0x81: return "NEWOBJ";
    case 0x82: return "EXT1";
    case 0x83: return "EXT2";
    case 0x84: return "EXT4";
    case 0x85: return "TUPLE1";
    case 0x86: return "TUPLE2";
    case 0x87: return "TUPLE3";
    case 0x88: return "NEWTRUE";
    case 0x89: return "NEWFALSE";
    case 0x8a: return "LONG1";
    case 0x8b: return "LONG4";
    case 'B': return "BINBYTES";
    case 'C': return "SHORT_BINBYTES";
    case 0x8c: return "SHORT_BINUNICODE";
    case 0x8d: return "BINUNICODE8";
    case 0x8e: return "BINBYTES8";
    case 0x8f: return "EMPTY_SET";
    case 0x90: return "ADDITEMS";
    case 0x91: return "FROZENSET";
    case 0x92: return "NEWOBJ_EX";
    case 0x93: return "STACK_GLOBAL";
    case 0x94: return "MEMOIZE";
    case 0x95: return "FRAME";
    case 0x96: return "BYTEARRAY8";
    case 0x97: return "NEXT_BUFFER";
    case 0x98: return "READONLY_BUFFER";
  }
  return "unknown";
}

// Little-endian two's-complement integer of n bytes → decimal string (for ints beyond int64).
std::string BigIntToDecimal(const uint8_t* p, size_t n) {
  std::vector<uint8_t> mag(p, p + n);
  const bool negative = n > 0 && (mag[n - 1] & 0x80);
  if (negative) {  // two's complement → magnitude
    int carry = 1;
    for (size_t k = 0; k < n; ++k) {
      const int v = static_cast<uint8_t>(~mag[k]) + carry;
      mag[k] = static_cast<uint8_t>(v & 0xff);
      carry = v >> 8;
    }
  }
  std::string digits;
  while (true) {
    bool zero = true;
    int rem = 0;
    for (size_t k = n; k-- > 0;) {
      const int cur = rem * 256 + mag[k];
      mag[k] = static_cast<uint8_t>(cur / 10);
      rem = cur % 10;
      if (mag[k]) zero = false;
    }
    digits.push_back(static_cast<char>('0' + rem));
    if (zero) break;
  }
  if (negative) digits.push_back('-');
  return std::string(digits.rbegin(), digits.rend());
}

class Unpickler {
 public:
  Unpickler(const uint8_t* data, size_t size, const std::string& what, const PersistentLoad& pl, const ReduceHook& rh,
            const PickleLimits& limits)
      : p_(data),
        end_(data + size),
        begin_(data),
        what_(what),
        persistent_load_(pl),
        reduce_hook_(rh),
        limits_(limits) {}
  Unpickler(const Unpickler&) = delete;
  Unpickler& operator=(const Unpickler&) = delete;
  // A stream refused half-way may have built reference cycles (a list appended to itself): cut every container's
  // edges so that nothing leaks.
  ~Unpickler() {
    stack_.clear();
    memo_.clear();
    for (const auto& o : containers_) {
      // After a successful parse only what the result cannot reach is cut (a cycle left on the stack or in the memo).
      if (ok_ && reachable_.count(o.get())) continue;
      o->items.clear();
      o->dict.clear();
      o->args.reset();
      o->state.reset();
    }
  }

  PyRef Run() {
    while (true) {
      FREELOC_CHECK(p_ < end_, what_ << ": pickle stream ends without STOP; the file is truncated");
      const size_t pos = static_cast<size_t>(p_ - begin_);
      const uint8_t op = *p_++;
      if (op == '.') {
        FREELOC_CHECK(!stack_.empty(), what_ << ": pickle STOP with an empty stack; the file is damaged");
        PyRef root = stack_.back();
        CheckShape(root);
        ok_ = true;
        return root;
      }
      if (ScalarOp(op) || ContainerOp(op, pos) || ObjectOp(op, pos)) continue;
      FREELOC_THROW(what_ << ": pickle opcode 0x" << std::hex << static_cast<int>(op) << std::dec << " ("
                          << OpcodeName(op) << ") at byte " << pos
                          << " is outside the subset freeloc reads; re-save the checkpoint with a current "
                             "torch.save (which writes protocol 2)");
    }
  }

 private:
  // Framing, constants, numbers, strings and bytes. False: not one of these opcodes.
  bool ScalarOp(uint8_t op) {
    switch (op) {
      case 0x80:
        Need(1);
        p_ += 1;
        return true;  // PROTO
      case 0x95:
        Need(8);
        p_ += 8;
        return true;  // FRAME: framing is transparent here
      case 'N': Push(PyObject::None()); return true;
      case 0x88: Push(PyObject::Bool(true)); return true;
      case 0x89: Push(PyObject::Bool(false)); return true;
      case 'J': {
        Need(4);
        int32_t v;
        std::memcpy(&v, p_, 4);
        p_ += 4;
        Push(PyObject::Int(v));
        return true;
      }
      case 'K': {
        Need(1);
        Push(PyObject::Int(*p_++));
        return true;
      }
      case 'M': {
        Need(2);
        Push(PyObject::Int(p_[0] | (p_[1] << 8)));
        p_ += 2;
        return true;
      }
      case 0x8a: {
        Need(1);
        const size_t n = *p_++;
        PushLong(n);
        return true;
      }
      case 0x8b: {
        const size_t n = ReadU32();
        PushLong(n);
        return true;
      }
      case 'G': {
        Need(8);
        uint64_t bits = 0;
        for (int k = 0; k < 8; ++k) bits = (bits << 8) | p_[k];  // big-endian
        p_ += 8;
        double v;
        std::memcpy(&v, &bits, 8);
        Push(PyObject::Float(v));
        return true;
      }
      case 'X': PushStr(ReadU32(), PyObject::Kind::kStr); return true;
      case 0x8c: {
        Need(1);
        const size_t n = *p_++;
        PushStr(n, PyObject::Kind::kStr);
        return true;
      }
      case 0x8d: PushStr(ReadU64(), PyObject::Kind::kStr); return true;
      case 'T': PushStr(ReadU32(), PyObject::Kind::kStr); return true;  // py2 str, decoded as text
      case 'U': {
        Need(1);
        const size_t n = *p_++;
        PushStr(n, PyObject::Kind::kStr);
        return true;
      }
      case 'B': PushStr(ReadU32(), PyObject::Kind::kBytes); return true;
      case 'C': {
        Need(1);
        const size_t n = *p_++;
        PushStr(n, PyObject::Kind::kBytes);
        return true;
      }
      case 0x8e: PushStr(ReadU64(), PyObject::Kind::kBytes); return true;
      case 0x96: PushStr(ReadU64(), PyObject::Kind::kBytes); return true;
      default: return false;
    }
  }
  // Marks and the stack, tuples, lists, sets and dicts.
  bool ContainerOp(uint8_t op, size_t pos) {
    switch (op) {
      case '(':
        FREELOC_CHECK(marks_.size() < limits_.max_objects,
                      what_ << ": pickle opens more than " << limits_.max_objects << " MARKs; refused");
        marks_.push_back(stack_.size());
        return true;
      case '0': Pop(); return true;
      case '1': PopMark(); return true;
      case '2': Push(Top()); return true;
      case ')': Push(NewSeq(PyObject::Kind::kTuple, {})); return true;
      case 't': Push(NewSeq(PyObject::Kind::kTuple, PopMark())); return true;
      case 0x85: {
        auto a = Pop();
        Push(NewSeq(PyObject::Kind::kTuple, {a}));
        return true;
      }
      case 0x86: {
        auto b = Pop();
        auto a = Pop();
        Push(NewSeq(PyObject::Kind::kTuple, {a, b}));
        return true;
      }
      case 0x87: {
        auto c = Pop();
        auto b = Pop();
        auto a = Pop();
        Push(NewSeq(PyObject::Kind::kTuple, {a, b, c}));
        return true;
      }
      case ']': Push(NewSeq(PyObject::Kind::kList, {})); return true;
      case 'l': Push(NewSeq(PyObject::Kind::kList, PopMark())); return true;
      case 'a': {
        auto v = Pop();
        Append(Top(), {v}, pos);
        return true;
      }
      case 'e': {
        auto items = PopMark();
        Append(Top(), items, pos);
        return true;
      }
      case 0x8f: Push(NewSeq(PyObject::Kind::kSet, {})); return true;
      case 0x90: {
        auto items = PopMark();
        Append(Top(), items, pos);
        return true;
      }
      case 0x91: Push(NewSeq(PyObject::Kind::kSet, PopMark())); return true;
      case '}': {
        auto d = std::make_shared<PyObject>();
        d->kind = PyObject::Kind::kDict;
        Push(Track(d));
        return true;
      }
      case 'd': {
        auto items = PopMark();
        auto d = std::make_shared<PyObject>();
        d->kind = PyObject::Kind::kDict;
        Track(d);
        SetItems(d, items, pos);
        Push(d);
        return true;
      }
      case 's': {
        auto v = Pop();
        auto k = Pop();
        SetItems(Top(), {k, v}, pos);
        return true;
      }
      case 'u': {
        auto items = PopMark();
        SetItems(Top(), items, pos);
        return true;
      }
      default: return false;
    }
  }
  // Globals, calls, BUILD, the memo and persistent ids.
  bool ObjectOp(uint8_t op, size_t pos) {
    switch (op) {
      case 'c': {
        const std::string module = ReadLine();
        const std::string name = ReadLine();
        Push(NewGlobal(module, name, pos));
        return true;
      }
      case 0x93: {
        auto name = Pop();
        auto module = Pop();
        FREELOC_CHECK(module->is(PyObject::Kind::kStr) && name->is(PyObject::Kind::kStr),
                      what_ << ": STACK_GLOBAL at byte " << pos << " needs two strings; the file is damaged");
        Push(NewGlobal(module->s, name->s, pos));
        return true;
      }
      case 'R': {
        auto args = Pop();
        auto callable = Pop();
        Push(Track(Call(callable, args, pos)));
        return true;
      }
      case 0x81: {
        auto args = Pop();
        auto cls = Pop();
        Push(Track(Call(cls, args, pos)));
        return true;
      }
      case 0x92: {
        Pop();
        auto args = Pop();
        auto cls = Pop();
        Push(Track(Call(cls, args, pos)));
        return true;
      }  // kwargs dropped
      case 'b': {
        auto state = Pop();
        auto obj = Top();
        if (obj->is(PyObject::Kind::kObject) || obj->is(PyObject::Kind::kDict)) {
          obj->state = state;
        }  // BUILD on a tensor (e.g. python-level attributes) or other value: nothing to keep.
        return true;
      }
      case 'q': {
        Need(1);
        Memo(*p_++);
        return true;
      }
      case 'r': {
        const size_t k = ReadU32();
        Memo(k);
        return true;
      }
      case 0x94: {
        const size_t k = memo_.size();
        Memo(k);
        return true;
      }
      case 'h': {
        Need(1);
        Push(MemoGet(*p_++, pos));
        return true;
      }
      case 'j': Push(MemoGet(ReadU32(), pos)); return true;
      case 'Q': {
        auto pid = Pop();
        FREELOC_CHECK(persistent_load_, what_ << ": persistent id at byte " << pos << " but no loader is set");
        Push(Track(persistent_load_(pid)));
        return true;
      }
      default: return false;
    }
  }
  void Need(size_t n) {
    FREELOC_CHECK(static_cast<size_t>(end_ - p_) >= n, what_ << ": pickle stream truncated at byte " << (p_ - begin_));
  }
  size_t ReadU32() {
    Need(4);
    uint32_t v;
    std::memcpy(&v, p_, 4);
    p_ += 4;
    return v;
  }
  size_t ReadU64() {
    Need(8);
    uint64_t v;
    std::memcpy(&v, p_, 8);
    p_ += 8;
    FREELOC_CHECK(v <= static_cast<uint64_t>(end_ - p_), what_ << ": pickle length field runs past the end");
    return static_cast<size_t>(v);
  }
  std::string ReadLine() {
    const uint8_t* nl = static_cast<const uint8_t*>(std::memchr(p_, '\n', end_ - p_));
    FREELOC_CHECK(nl != nullptr, what_ << ": GLOBAL name not terminated; the file is damaged");
    std::string s(reinterpret_cast<const char*>(p_), nl - p_);
    p_ = nl + 1;
    return s;
  }
  void PushStr(size_t n, PyObject::Kind kind) {
    Need(n);
    auto o = std::make_shared<PyObject>();
    o->kind = kind;
    o->s.assign(reinterpret_cast<const char*>(p_), n);
    p_ += n;
    Push(o);
  }
  void PushLong(size_t n) {
    Need(n);
    FREELOC_CHECK(n <= limits_.max_long_bytes, what_ << ": pickle integer of " << n << " bytes at byte "
                                                     << (p_ - begin_) << " exceeds the limit of "
                                                     << limits_.max_long_bytes << " bytes; refused");
    if (n <= 8) {
      uint64_t u = 0;
      for (size_t k = 0; k < n; ++k) u |= static_cast<uint64_t>(p_[k]) << (8 * k);
      if (n > 0 && n < 8 && (p_[n - 1] & 0x80)) u |= ~0ull << (8 * n);  // sign-extend
      p_ += n;
      int64_t v;
      std::memcpy(&v, &u, 8);
      Push(PyObject::Int(v));
      return;
    }
    auto o = std::make_shared<PyObject>();
    o->kind = PyObject::Kind::kBigInt;
    o->s = BigIntToDecimal(p_, n);
    p_ += n;
    Push(o);
  }
  void Push(PyRef v) {
    FREELOC_CHECK(++pushed_ <= limits_.max_objects,
                  what_ << ": pickle pushes more than " << limits_.max_objects << " values; refused as a memory bomb");
    stack_.push_back(std::move(v));
  }
  void Memo(size_t k) {
    FREELOC_CHECK(memo_.size() < limits_.max_objects,
                  what_ << ": pickle memo exceeds " << limits_.max_objects << " entries; refused as a memory bomb");
    memo_[k] = Top();
  }
  PyRef Track(PyRef o) {
    if (o && o->kind != PyObject::Kind::kTensor) containers_.push_back(o);
    return o;
  }
  // After STOP: the object graph must be acyclic, at most `max_depth` deep, and small when every shared reference
  // is followed (a 379-byte DAG can otherwise stand for 2^60 objects). One iterative post-order walk.
  void CheckShape(const PyRef& root) {
    struct Info {
      bool done = false;
      size_t height = 1, expanded = 1;
    };
    std::unordered_map<const PyObject*, Info> info;
    struct Frame {
      const PyObject* o;
      std::vector<const PyObject*> children;
      size_t next = 0;
    };
    auto children_of = [](const PyObject* o) {
      std::vector<const PyObject*> c;
      for (const auto& x : o->items) c.push_back(x.get());
      for (const auto& [k, v] : o->dict) {
        c.push_back(k.get());
        c.push_back(v.get());
      }
      if (o->args) c.push_back(o->args.get());
      if (o->state) c.push_back(o->state.get());
      return c;
    };
    std::vector<Frame> stack;
    stack.push_back({root.get(), children_of(root.get())});
    info[root.get()];
    while (!stack.empty()) {
      Frame& f = stack.back();
      if (f.next < f.children.size()) {
        const PyObject* c = f.children[f.next++];
        auto [it, fresh] = info.try_emplace(c);
        if (fresh) {
          FREELOC_CHECK(stack.size() < limits_.max_depth,
                        what_ << ": pickle objects nest more than " << limits_.max_depth << " deep; refused");
          stack.push_back({c, children_of(c)});
        } else {
          FREELOC_CHECK(it->second.done, what_ << ": pickle holds a reference cycle (a container inside itself); "
                                                  "checkpoints never do — refused");
        }
        continue;
      }
      Info& me = info[f.o];
      for (const PyObject* c : f.children) {
        const Info& ci = info[c];
        me.height = std::max(me.height, ci.height + 1);
        me.expanded = std::min(me.expanded + ci.expanded, limits_.max_expanded + 1);
      }
      FREELOC_CHECK(me.height <= limits_.max_depth,
                    what_ << ": pickle objects nest more than " << limits_.max_depth << " deep; refused");
      FREELOC_CHECK(me.expanded <= limits_.max_expanded,
                    what_ << ": pickle stands for more than " << limits_.max_expanded
                          << " objects once its shared references are followed; refused as a bomb");
      me.done = true;
      stack.pop_back();
    }
    for (const auto& [o, i] : info) reachable_.insert(o);
  }
  PyRef Pop() {
    FREELOC_CHECK(!stack_.empty() && (marks_.empty() || stack_.size() > marks_.back()),
                  what_ << ": pickle stack underflow at byte " << (p_ - begin_ - 1) << "; the file is damaged");
    PyRef v = stack_.back();
    stack_.pop_back();
    return v;
  }
  PyRef Top() {
    FREELOC_CHECK(!stack_.empty(), what_ << ": pickle stack underflow at byte " << (p_ - begin_ - 1));
    return stack_.back();
  }
  std::vector<PyRef> PopMark() {
    FREELOC_CHECK(!marks_.empty(),
                  what_ << ": pickle MARK missing at byte " << (p_ - begin_ - 1) << "; the file is damaged");
    const size_t m = marks_.back();
    marks_.pop_back();
    std::vector<PyRef> items(stack_.begin() + m, stack_.end());
    stack_.resize(m);
    return items;
  }
  PyRef MemoGet(size_t k, size_t pos) {
    auto it = memo_.find(k);
    FREELOC_CHECK(it != memo_.end(),
                  what_ << ": pickle memo entry " << k << " read at byte " << pos << " was never stored");
    return it->second;
  }
  PyRef NewSeq(PyObject::Kind kind, std::vector<PyRef> items) {
    auto o = std::make_shared<PyObject>();
    o->kind = kind;
    o->items = std::move(items);
    return Track(o);
  }
  PyRef NewGlobal(const std::string& module, const std::string& name, size_t pos) {
    FREELOC_CHECK(IsAllowedPickleGlobal(module, name),
                  what_ << ": pickle names the global " << SafeText(module) << "." << SafeText(name) << " at byte "
                        << pos << ", which is not one of the classes checkpoints use (torch tensors and storages, "
                        << "OrderedDict, argparse.Namespace, builtin containers, numpy scalars); refused");
    auto o = std::make_shared<PyObject>();
    o->kind = PyObject::Kind::kGlobal;
    o->module = module;
    o->name = name;
    return o;
  }
  void Append(const PyRef& target, const std::vector<PyRef>& items, size_t pos) {
    if (target->is(PyObject::Kind::kList) || target->is(PyObject::Kind::kSet) || target->is(PyObject::Kind::kObject)) {
      target->items.insert(target->items.end(), items.begin(), items.end());
      return;
    }
    FREELOC_THROW(what_ << ": APPEND to a " << target->KindName() << " at byte " << pos << "; the file is damaged");
  }
  void SetItems(const PyRef& target, const std::vector<PyRef>& kv, size_t pos) {
    FREELOC_CHECK(kv.size() % 2 == 0, what_ << ": odd number of SETITEMS values at byte " << pos);
    FREELOC_CHECK(target->is(PyObject::Kind::kDict) || target->is(PyObject::Kind::kObject),
                  what_ << ": SETITEM on a " << target->KindName() << " at byte " << pos << "; the file is damaged");
    for (size_t k = 0; k < kv.size(); k += 2) {
      bool replaced = false;
      if (kv[k]->is(PyObject::Kind::kStr)) {
        for (auto& [key, value] : target->dict) {
          if (key->is(PyObject::Kind::kStr) && key->s == kv[k]->s) {
            value = kv[k + 1];
            replaced = true;
            break;
          }
        }
      }
      if (!replaced) target->dict.emplace_back(kv[k], kv[k + 1]);
    }
  }
  PyRef Call(const PyRef& callable, const PyRef& args, size_t pos) {
    FREELOC_CHECK(callable->is(PyObject::Kind::kGlobal),
                  what_ << ": REDUCE/NEWOBJ on a " << callable->KindName() << " at byte " << pos
                        << " (only classes and functions named by GLOBAL can be called)");
    if (reduce_hook_) {
      PyRef r = reduce_hook_(callable->module, callable->name, args);
      if (r) return r;
    }
    const std::string& m = callable->module;
    const std::string& n = callable->name;
    if (m == "collections" && n == "OrderedDict") {
      auto d = std::make_shared<PyObject>();
      d->kind = PyObject::Kind::kDict;
      return d;
    }
    if ((m == "builtins" || m == "__builtin__") && (n == "set" || n == "frozenset" || n == "list" || n == "tuple")) {
      auto o = NewSeq(n == "list"    ? PyObject::Kind::kList
                      : n == "tuple" ? PyObject::Kind::kTuple
                                     : PyObject::Kind::kSet,
                      {});
      if (args && !args->items.empty()) o->items = args->items[0]->items;
      return o;
    }
    if (m == "_codecs" && n == "encode" && args && !args->items.empty() && args->items[0]->is(PyObject::Kind::kStr)) {
      // Protocol-2 bytes: _codecs.encode(text, 'latin1'). Undo the UTF-8 of the latin-1 text.
      const std::string& t = args->items[0]->s;
      std::string bytes;
      for (size_t k = 0; k < t.size(); ++k) {
        const unsigned char c = t[k];
        if (c < 0x80) {
          bytes.push_back(static_cast<char>(c));
        } else if (k + 1 < t.size()) {
          bytes.push_back(static_cast<char>(((c & 0x1f) << 6) | (static_cast<unsigned char>(t[k + 1]) & 0x3f)));
          ++k;
        }
      }
      auto o = std::make_shared<PyObject>();
      o->kind = PyObject::Kind::kBytes;
      o->s = bytes;
      return o;
    }
    // Anything else: an opaque object that remembers its class, arguments and (later) BUILD state.
    auto o = std::make_shared<PyObject>();
    o->kind = PyObject::Kind::kObject;
    o->module = m;
    o->name = n;
    o->args = args;
    return o;
  }

  const uint8_t* p_;
  const uint8_t* end_;
  const uint8_t* begin_;
  std::string what_;
  const PersistentLoad& persistent_load_;
  const ReduceHook& reduce_hook_;
  PickleLimits limits_;
  bool ok_ = false;
  size_t pushed_ = 0;
  std::vector<PyRef> containers_;
  std::unordered_set<const PyObject*> reachable_;
  std::vector<PyRef> stack_;
  std::vector<size_t> marks_;
  std::unordered_map<size_t, PyRef> memo_;
};

}  // namespace

PyRef ParsePickle(const uint8_t* data, size_t size, const std::string& what, const PersistentLoad& persistent_load,
                  const ReduceHook& reduce_hook, const PickleLimits& limits) {
  Unpickler u(data, size, what, persistent_load, reduce_hook, limits);
  return u.Run();
}

}  // namespace freeloc::io
