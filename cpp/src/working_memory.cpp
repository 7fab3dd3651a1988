#include "working_memory.hpp"

#include "memory.hpp"

#include <liff/liff.hpp>
#include <opencv2/core.hpp>

#include <algorithm>
#include <map>
#include <mutex>
#include <unordered_map>

#if defined(__unix__) || defined(__APPLE__)
#include <pthread.h>
#endif
#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace liff {
namespace detail {
namespace {

// Keeps freed buffers of kKeptBufferMinBytes and more so that in use plus kept stays
// within kKeptPeakShare times the most this process has had in use at once (the
// largest call so far, concurrent calls summed). Smaller buffers and Mats over caller
// data go to OpenCV's standard allocator.
class ReusingAllocator : public cv::MatAllocator {
  struct Kept {
    void* data;
    unsigned long lastUse;  // the call count when it was last taken
  };
  using FreeList = std::multimap<size_t, Kept>;  // capacity -> kept buffer

 public:
  cv::UMatData* allocate(int dims, const int* sizes, int type, void* data0, size_t* step,
                         cv::AccessFlag flags, cv::UMatUsageFlags usage) const override {
    const cv::MatAllocator* standard = cv::Mat::getStdAllocator();
    if (data0) return standard->allocate(dims, sizes, type, data0, step, flags, usage);
    size_t total = CV_ELEM_SIZE(type);
    for (int i = dims - 1; i >= 0; --i) total *= sizes[i];
    if (total < kKeptBufferMinBytes)
      return standard->allocate(dims, sizes, type, data0, step, flags, usage);
    // Continuous, as the standard allocator lays a Mat out.
    if (step) {
      size_t bytes = CV_ELEM_SIZE(type);
      for (int i = dims - 1; i >= 0; --i) {
        step[i] = bytes;
        bytes *= sizes[i];
      }
    }
    cv::UMatData* u = new cv::UMatData(this);
    u->data = u->origdata = take(total);
    u->size = total;
    return u;
  }

  bool allocate(cv::UMatData* u, cv::AccessFlag, cv::UMatUsageFlags) const override {
    return u != nullptr;
  }

  void deallocate(cv::UMatData* u) const override {
    if (!u) return;
    CV_Assert(u->urefcount == 0 && u->refcount == 0);
    give(u->origdata);
    u->origdata = nullptr;
    delete u;
  }

  void release() {
    std::lock_guard<std::mutex> lock(mutex_);
    while (!free_.empty()) drop(free_.begin());
    freeBytes_ = 0;
    peakBytes_ = inUseBytes_;  // a later call sizes the reuse anew
  }

  // Held across fork() (pthread_atfork), so that a child forked while another thread
  // allocates does not inherit the lock held, and with it a deadlock on its first Mat.
  void lockForFork() const { mutex_.lock(); }
  void unlockAfterFork() const { mutex_.unlock(); }

  void beginCall() {
    std::lock_guard<std::mutex> lock(mutex_);
    ++generation_;
  }

  size_t keptBytes() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return freeBytes_;
  }

  // The most bytes in use plus kept since the last reset; a reset starts from now's.
  size_t heldPeak(bool reset) {
    std::lock_guard<std::mutex> lock(mutex_);
    const size_t peak = heldPeak_;
    if (reset) heldPeak_ = inUseBytes_ + freeBytes_;
    return peak;
  }

 private:
  // A kept buffer of `bytes` or a little more (best fit), else a new one.
  uchar* take(size_t bytes) const {
    std::lock_guard<std::mutex> lock(mutex_);
    auto fit = free_.lower_bound(bytes);
    if (fit != free_.end() && double(bytes) >= kKeptBufferMinFill * double(fit->first)) {
      uchar* data = static_cast<uchar*>(fit->second.data);
      freeBytes_ -= fit->first;
      inUseBytes_ += fit->first;
      free_.erase(fit);
      lastUse_[data] = generation_;
      return data;
    }
    // A miss. Buffers no call used since the one before this one are of sizes the calls
    // no longer ask for (a light field of another size): give them back. Then, should
    // in use plus kept still exceed the bound, the largest kept ones the last call used
    // but this one has not (yet).
    for (auto it = free_.begin(); it != free_.end();)
      it = it->second.lastUse + 1 < generation_ ? drop(it) : std::next(it);
    peakBytes_ = std::max(peakBytes_, inUseBytes_ + bytes);
    for (auto it = free_.end(); it != free_.begin() &&
                                inUseBytes_ + bytes + freeBytes_ > kKeptPeakShare * peakBytes_;) {
      --it;  // largest first; this call's own buffers stay (it will ask for them again)
      if (it->second.lastUse < generation_) it = drop(it);
    }
    uchar* data = static_cast<uchar*>(cv::fastMalloc(bytes));
    capacity_[data] = bytes;
    lastUse_[data] = generation_;
    inUseBytes_ += bytes;
    heldPeak_ = std::max(heldPeak_, inUseBytes_ + freeBytes_);
    return data;
  }

  // Frees a kept buffer; returns the next one.
  FreeList::iterator drop(FreeList::iterator it) const {
    freeBytes_ -= it->first;
    capacity_.erase(it->second.data);
    lastUse_.erase(it->second.data);
    cv::fastFree(it->second.data);
    return free_.erase(it);
  }

  void give(uchar* data) const {
    std::lock_guard<std::mutex> lock(mutex_);
    const size_t capacity = capacity_.at(data);
    inUseBytes_ -= capacity;
    if (enabled_ && inUseBytes_ + freeBytes_ + capacity <= kKeptPeakShare * peakBytes_) {
      free_.emplace(capacity, Kept{data, lastUse_.at(data)});
      freeBytes_ += capacity;
    } else {
      capacity_.erase(data);
      lastUse_.erase(data);
      cv::fastFree(data);
    }
  }

 public:
  void setEnabled(bool enabled) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      enabled_ = enabled;
    }
    if (!enabled) release();
  }

 private:
  mutable std::mutex mutex_;
  mutable FreeList free_;
  mutable std::unordered_map<void*, size_t> capacity_;         // every buffer of ours
  mutable std::unordered_map<void*, unsigned long> lastUse_;   // every buffer of ours
  mutable unsigned long generation_ = 0;                       // calls begun
  mutable size_t freeBytes_ = 0, inUseBytes_ = 0, peakBytes_ = 0;
  mutable size_t heldPeak_ = 0;  // the most in use plus kept since heldPeak(true)
  bool enabled_ = true;
};

// Never destroyed: Mats may be freed during static destruction, after any static
// object of ours would be gone.
ReusingAllocator& allocator() {
  static ReusingAllocator* instance = new ReusingAllocator;
  return *instance;
}

std::once_flag installed;
bool reuseWanted = true;
std::mutex settingMutex;

}  // namespace

void installWorkingMemory() {
  std::call_once(installed, [] {
    std::lock_guard<std::mutex> lock(settingMutex);
    if (reuseWanted) cv::Mat::setDefaultAllocator(&allocator());
#if defined(__unix__) || defined(__APPLE__)
    pthread_atfork([] { allocator().lockForFork(); }, [] { allocator().unlockAfterFork(); },
                   [] { allocator().unlockAfterFork(); });
#endif
  });
  allocator().beginCall();
}

}  // namespace detail

void releaseWorkingMemory() {
  detail::allocator().release();
#if defined(__GLIBC__)
  malloc_trim(0);  // glibc keeps freed heap memory otherwise: give it back to the system
#endif
}

size_t keptWorkingMemoryBytes() { return detail::allocator().keptBytes(); }

size_t detail::workingMemoryPeakBytes(bool reset) { return detail::allocator().heldPeak(reset); }

double availableMemoryBytes() { return detail::availableMemoryBytes(); }

void setWorkingMemoryReuse(bool enabled) {
  std::lock_guard<std::mutex> lock(detail::settingMutex);
  detail::reuseWanted = enabled;
  detail::allocator().setEnabled(enabled);
}

bool getWorkingMemoryReuse() {
  std::lock_guard<std::mutex> lock(detail::settingMutex);
  return detail::reuseWanted;
}

}  // namespace liff
