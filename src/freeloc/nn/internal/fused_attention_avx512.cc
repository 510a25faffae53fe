// The fused attention kernel (fused_attention_kernel.inc) built for the avx512 entry; nn/CMakeLists.txt gives this file
// its instruction-set flags. Chosen at run time by fused_attention.cc.
#define FA_ENTRY kAvx512
#define FA_NAME "avx512"
#define FA_BF16 0
#define FA_ROWS 6
#define FA_VL 16
#include "freeloc/nn/internal/fused_attention_kernel.inc"
