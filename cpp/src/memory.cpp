#include "memory.hpp"

#include <liff/liff.hpp>

#include "focal_stack.hpp"
#include "scale_space.hpp"

#include <algorithm>
#include <fstream>
#include <limits>
#include <string>

namespace liff {
namespace detail {
namespace {

// First number in a file (cgroup limits: "max" means none), or -1.
double readNumber(const char* path) {
  std::ifstream in(path);
  std::string word;
  if (!(in >> word) || word == "max") return -1;
  try {
    return std::stod(word);
  } catch (const std::exception&) {
    return -1;
  }
}

// MemAvailable (kB) from /proc/meminfo, in bytes, or -1.
double memAvailable() {
  std::ifstream in("/proc/meminfo");
  std::string key, unit;
  double kb = 0;
  while (in >> key >> kb) {
    std::getline(in, unit);
    if (key == "MemAvailable:") return kb * 1024.0;
  }
  return -1;
}

// The value of `key` in a cgroup memory.stat file, or 0.
double statValue(const char* path, const std::string& key) {
  std::ifstream in(path);
  std::string name;
  double value = 0;
  while (in >> name >> value)
    if (name == key) return value;
  return 0;
}

// Room left under this process's cgroup memory limit, in bytes, or -1 if none. Usage
// counts the page cache; its inactive file pages are reclaimable, so they count as room
// (as docker and the kubelet do), or reading large files would look like running out.
double cgroupRoom() {
  // cgroup v2 (unified) at the root of the container's view, then v1.
  const double v2Max = readNumber("/sys/fs/cgroup/memory.max");
  if (v2Max > 0) {
    const double used = readNumber("/sys/fs/cgroup/memory.current") -
                        statValue("/sys/fs/cgroup/memory.stat", "inactive_file");
    return std::max(1.0, v2Max - std::max(0.0, used));
  }
  const double v1Max = readNumber("/sys/fs/cgroup/memory/memory.limit_in_bytes");
  // v1 reports "no limit" as a huge number (about 2^63 rounded to pages).
  if (v1Max > 0 && v1Max < 1e18) {
    const double used = readNumber("/sys/fs/cgroup/memory/memory.usage_in_bytes") -
                        statValue("/sys/fs/cgroup/memory/memory.stat", "total_inactive_file");
    return std::max(1.0, v1Max - std::max(0.0, used));
  }
  return -1;
}

}  // namespace

namespace {

// Size of the first octave's images: the view upsampled as buildScaleSpace does.
cv::Size firstOctaveSize(cv::Size viewSize, int firstOctave) {
  const int upsample = 1 << -firstOctave;
  return cv::Size(viewSize.width * upsample, viewSize.height * upsample);
}

}  // namespace

double scaleSpaceBytes(cv::Size viewSize, int layers, int octaves, int firstOctave,
                       bool detectionOnly) {
  const int gaussians = detectionOnly ? layers : layers + 3, dogs = layers + 2;
  double pixels = 0;
  cv::Size size = firstOctaveSize(viewSize, firstOctave);
  for (int o = 0; o < octaves; ++o) {
    pixels += double(size.width) * size.height;
    size = cv::Size(std::max(1, size.width / 2), std::max(1, size.height / 2));
  }
  return pixels * (gaussians + dogs) * sizeof(float);
}

MemoryEstimate sliceMemory(cv::Size viewSize, int layers, int octaves, int firstOctave,
                           bool describing, size_t described, int descriptorBytes) {
  MemoryEstimate need;
  need.describing = describing;
  if (octaves < 1) return need;
  const double firstOctavePixels = double(firstOctaveSize(viewSize, firstOctave).area());
  need.sliceBytes = scaleSpaceBytes(viewSize, layers, octaves, firstOctave, !describing);
  // BuildScratch: the upsampled base (firstOctave 0 blurs the focal slice itself) and,
  // for a detection-only pyramid, three first-octave images for the layers it drops.
  const int images = (firstOctave < 0 ? 1 : 0) + (describing ? 0 : 3);
  need.scratchBytes = images * firstOctavePixels * sizeof(float);
  need.focalSliceBytes = double(viewSize.area()) * sizeof(float);
  need.slicesPerPass = kSlicesPerPass;
  need.keypoints = describing ? double(described) : kKeypointsPerPixel * firstOctavePixels;
  // Detection writes each batch's descriptors into a block, then copies them, sorted,
  // into the output; compute() into a zeroed array through a block per group of slices,
  // then into the output.
  need.keypointBytes = (describing ? 3.0 : 2.0) * descriptorBytes + kKeypointRecordBytes;
  return need;
}

double availableMemoryBytes() {
  const double available = memAvailable(), room = cgroupRoom();
  // Memory the core keeps for reuse is free for the call.
  const double kept = double(keptWorkingMemoryBytes());
  if (available < 0) return room > 0 ? room + kept : 0;
  return (room >= 0 ? std::min(available, room) : available) + kept;
}

}  // namespace detail
}  // namespace liff
