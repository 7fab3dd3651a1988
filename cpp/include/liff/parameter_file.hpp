// Parameter files are input: their size and nesting are checked before OpenCV's
// FileStorage parses them. Its YAML, JSON and XML parsers recurse once per nesting
// level without a limit (a 150 KB file nested 75,000 levels deep overflows the stack)
// and read a file of any size; a parameter file is a flat map of numbers, so small
// limits cost nothing (docs/RELIABILITY.md).
#pragma once

#include <opencv2/core.hpp>

#include <cstddef>
#include <string>

namespace liff {

/// The deepest nesting a parameter document may have: a map in a map, a sequence
/// or an XML element each count one level. LiFF's own files use 1, Algorithm::save()'s
/// 2, a matrix written beside them 3.
constexpr int kMaxParameterNesting = 64;

/// The largest parameter document read, in bytes (1 MiB; LiFF's own files are about
/// 300 bytes).
constexpr std::size_t kMaxParameterFileBytes = std::size_t(1) << 20;

/// Throws cv::Exception (cv::Error::StsParseError) naming `source` (how the message
/// names the document: "parameter file 'p.yml'") and the line if the
/// FileStorage document `text` is larger than kMaxParameterFileBytes, holds a NUL byte,
/// a lone carriage return or base64 data, nests deeper than kMaxParameterNesting, or
/// (YAML) is laid out so that OpenCV 4's parser would loop forever: each document's root
/// must start at column 0 as a block map or sequence, and a "..." line be followed by
/// "---", a directive or the end.
/// The check overestimates the nesting (brackets in strings and comments may count,
/// never the reverse), so that no document it passes can recurse deeper in OpenCV.
void checkParameterText(const std::string& text, const std::string& source);

/// Parses the FileStorage document `text` (YAML, JSON or XML, as OpenCV tells them
/// apart) for reading, after checkParameterText. Throws cv::Exception
/// (cv::Error::StsParseError) naming `source` for a document either refuses.
cv::FileStorage openParameterText(const std::string& text, const std::string& source);

/// Reads the file at `path` (a regular file, refused otherwise: a FIFO or device would
/// block or never end) and opens it with openParameterText. Throws cv::Exception:
/// cv::Error::StsBadArg if it is not a regular file or cannot be read, StsParseError if
/// it is refused or cannot be parsed.
cv::FileStorage openParameterFile(const std::string& path);

}  // namespace liff
