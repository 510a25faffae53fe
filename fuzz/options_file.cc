// libFuzzer target: an options file (`--options FILE`, pipeline::ReadOptionsFile) and what the command line does with
// it — every pipeline option by its name (SetOption), every run field (SetRunField), then Validate. Whatever the file
// holds, the answer is the options or an Error naming the field or the file.
#include "freeloc/pipeline/record.h"
#include "freeloc/pipeline/run_fields.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace freeloc;
  fuzz::Expect([&] {
    const pipeline::OptionsFile f = pipeline::ReadOptionsFile(fuzz::AsFile(data, size, ".json"));
    pipeline::PipelineOptions o;
    for (const auto& kv : f.options) fuzz::Expect([&] { pipeline::SetOption(&o, kv.first, kv.second); });
    pipeline::RunSpec spec;
    for (const auto& kv : f.run) fuzz::Expect([&] { pipeline::SetRunField(&spec, kv.first, kv.second); });
    o.Validate();
  });
  return 0;
}
