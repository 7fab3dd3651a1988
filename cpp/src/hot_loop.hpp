// LIFF_HOT_LOOP: builds a small hot loop for AVX2 as well as the x86-64 baseline and
// picks the version at run time (GCC/Clang function multiversioning on Linux).
// AVX2 without FMA keeps every result bit-identical to the baseline build.
// LIFF_COMPARE_LOOP: a loop of comparisons only (nothing rounded), built for AVX-512 too.
// LIFF_FMA_LOOP: the blur's loops, with fused multiply-adds where the CPU has them
// (x86-64-v3, and v4 where its 16-float vectors, Vec16, fill AVX-512 registers: the same
// operations per lane, so v3 and v4 give the same results bit for bit).
#pragma once

#if defined(__x86_64__) && defined(__linux__) && (defined(__GNUC__) || defined(__clang__))
#define LIFF_HOT_LOOP __attribute__((target_clones("avx2", "default")))
#define LIFF_FMA_LOOP \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#define LIFF_COMPARE_LOOP \
  __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#else
#define LIFF_HOT_LOOP
#define LIFF_FMA_LOOP
#define LIFF_COMPARE_LOOP
#endif
