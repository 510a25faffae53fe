// The fused attention kernel (fused_attention_kernel.inc) built for the generic entry; nn/CMakeLists.txt gives this
// file its instruction-set flags. Chosen at run time by fused_attention.cc.
#define FA_ENTRY kGeneric
#define FA_NAME "generic"
#define FA_BF16 0
#define FA_ROWS 2
#define FA_VL 4
#include "freeloc/nn/internal/fused_attention_kernel.inc"
