// freeloc's heavy parts — the networks (LibTorch) and OpenCV's image codecs — are shared libraries loaded on first
// use, so commands that need neither start in milliseconds (`freeloc --version`, `pose`, `eval`, …).
// A module exports one C entry point returning a table of functions; the caller declares the table (light header)
// and looks it up here. The library is found: already loaded (a program that links it) → beside the freeloc library
// that holds this loader (build tree and install prefix alike) → the dynamic linker's search path.
#pragma once

#include <string>

#include "freeloc/core/error.h"

namespace freeloc {

// The address of `entry` in the freeloc module `library` (e.g. "libfreeloc_networks.so"), loading it on first call.
// `purpose` names what needs it, for the error. Throws freeloc::Error with the loader's message when the module is
// missing or broken (an incomplete installation). Thread-safe.
void* LoadModuleEntry(const std::string& library, const char* entry, const std::string& purpose);

// The table `entry` returns (a struct whose first member is `int abi`), checked against the `abi` this build
// expects. Callers keep the reference (e.g. in a function-local static): a module is loaded once per process.
template <class Table>
const Table& LoadModuleTable(const std::string& library, const char* entry, int abi, const std::string& purpose) {
  using Entry = const Table* (*)();
  const Table* table = reinterpret_cast<Entry>(LoadModuleEntry(library, entry, purpose))();
  FREELOC_CHECK(table != nullptr && table->abi == abi, library << " belongs to another freeloc version; reinstall");
  return *table;
}

// Whether `library` is loaded in this process (linked, or loaded by LoadModuleEntry).
bool ModuleLoaded(const std::string& library);

// The folder holding the freeloc libraries (where modules are looked for first).
std::string ModuleDirectory();

}  // namespace freeloc
