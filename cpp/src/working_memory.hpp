// The core's working memory, kept from call to call: an OpenCV allocator that keeps
// the large buffers a detection frees (grey light field, focal slices, scale spaces)
// and hands them to the next call, so a second call does not fault in and zero its
// pages again, whatever the C library's allocator settings and in any thread.
#pragma once

#include <cstddef>

namespace liff {
namespace detail {

/// Buffers of at least a page are kept for reuse: glibc maps those over its mmap
/// threshold afresh on each call and gives the top of its heaps back once more than
/// M_TRIM_THRESHOLD is free there (Dask's nanny sets it to 64 KiB), so smaller ones
/// would be faulted in again too. Smaller buffers cost no page of their own.
constexpr size_t kKeptBufferMinBytes = 4096;
/// In use plus kept stays within this multiple of the most ever in use at once: a call's
/// phases use buffers of different sizes (the slope survey's decimated light fields,
/// then the focal slices and scale spaces), all of which the next call asks for again,
/// so keeping them all takes more than the peak of any one moment (1.3x on the
/// Illum-size scene).
constexpr double kKeptPeakShare = 2.0;
/// A kept buffer serves a request of at least this share of its size (best fit): calls
/// ask for the same sizes again, and a larger one would sit idle beside a new buffer.
constexpr double kKeptBufferMinFill = 0.5;

/// Called at the start of each call: makes the reusing allocator the system OpenCV's
/// default for Mats (the first time, unless reuse was turned off) and counts the call
/// (kept buffers no call has used since the one before are given back on a miss).
void installWorkingMemory();

/// The most bytes of the core's buffers (those of kKeptBufferMinBytes and more) in use
/// and kept at once since the last reset; `reset` starts the count again from what is
/// held now. For the tests and benchmarks/memory.py, which compare it with the estimate.
size_t workingMemoryPeakBytes(bool reset);

}  // namespace detail
}  // namespace liff
