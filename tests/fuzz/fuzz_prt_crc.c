/* fuzz_prt_crc.c - fuzz_prt.c with the frame (payload length, CRC-32) recomputed before reading,
 * so mutations reach the sections' checks and the relighting. */
#define FUZZ_FIX_CRC 1
#include "fuzz_prt.c"
