// The checks on a parameter document before OpenCV's FileStorage parses it
// (liff/parameter_file.hpp): size, text, and an upper bound of its nesting depth.
//
// The bound must never be below the depth OpenCV's parsers recurse to, whatever the
// bytes, and may be above it for odd files (a parameter file is flat). So an opening
// bracket, brace or tag counts wherever it is, even in a string or a comment, while a
// closing one counts only where it is surely structure: outside the strings and
// comments as lexed here, and never on the rest of a line where the lexing could
// differ from OpenCV's (after a quote, a backslash, a YAML tag or comment).
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <liff/parameter_file.hpp>
#include <liff/parameters.hpp>
#include <type_traits>
#include <vector>

namespace liff {
namespace {

enum class Format { Yaml, Json, Xml };

[[noreturn]] void refuse(const std::string& source, const std::string& what) {
  CV_Error(cv::Error::StsParseError, "LiFF: " + source + " " + what);
}

// The nesting seen so far; refuses the document once it exceeds the limit.
class Depth {
 public:
  explicit Depth(const std::string& source) : source_(source) {}
  void check(int depth, int line) const {
    if (depth > kMaxParameterNesting)
      refuse(source_, cv::format("nests more than %d levels deep (line %d); expected at most "
                                 "%d: a parameter file is a flat map of numbers",
                                 kMaxParameterNesting, line, kMaxParameterNesting));
  }

 private:
  const std::string& source_;
};

bool startsWith(const std::string& text, std::size_t at, const char* prefix) {
  return text.compare(at, std::char_traits<char>::length(prefix), prefix) == 0;
}

// JSON: [ and { open, ] and } close outside strings and // or /* */ comments. A
// backslash in a string (OpenCV's key parser does not take escapes) makes the rest of
// its line uncertain: closers there do not count, and a /* there may open a comment.
void scanJson(const std::string& text, std::size_t start, const std::string& source) {
  const Depth limit(source);
  enum class State { Code, String, LineComment, BlockComment } state = State::Code;
  int depth = 0, line = 1;
  bool uncertain = false, maybeComment = false;
  for (std::size_t i = start; i < text.size(); ++i) {
    const char c = text[i], next = i + 1 < text.size() ? text[i + 1] : '\0';
    if (c == '\n') {
      ++line;
      if (state == State::String || state == State::LineComment) state = State::Code;
      if (maybeComment) state = State::BlockComment;
      uncertain = maybeComment = false;
      continue;
    }
    if (c == '[' || c == '{') limit.check(++depth, line);
    if (uncertain && c == '/' && next == '*') maybeComment = true;
    if (uncertain && c == '*' && next == '/') maybeComment = false;
    switch (state) {
      case State::Code:
        if (c == '"') {
          state = State::String;
        } else if (c == '/' && next == '/') {
          state = State::LineComment;
          ++i;
        } else if (c == '/' && next == '*') {
          state = State::BlockComment;
          ++i;
        } else if ((c == ']' || c == '}') && !uncertain) {
          depth = std::max(0, depth - 1);
        }
        break;
      case State::String:
        if (c == '\\') {
          uncertain = true;
          if (next != '\n') ++i;
        } else if (c == '"') {
          state = State::Code;
        }
        break;
      case State::LineComment:
        break;
      case State::BlockComment:
        if (c == '*' && next == '/') {
          state = State::Code;
          ++i;
        }
        break;
    }
  }
}

// YAML (OpenCV's subset). Flow collections: [ and { open; ] and } close only before
// the first #, quote or ! of their line (comments, quoted strings, type tags) and
// when no ':' follows on the line (a key of a flow map may hold brackets). Block
// collections: each '-' after a space, ':' or '-' (or first on its line) and each ':'
// may open one, at a column no further right than OpenCV's (a '-' at its own, a key
// where the text after the previous '-' or ':' begins); a line that starts at a column
// closes those to its right, as in OpenCV (unless inside a flow, where lines close
// nothing). Several may open on one line ("- - - x", "a: b: c: x", "!t - !t - x",
// "!x: !x: 1": a value may have one type tag, then a key).
void scanYaml(const std::string& text, std::size_t start, const std::string& source) {
  const Depth limit(source);
  std::vector<std::size_t> blocks;  // columns of the block collections that may be open
  int flow = 0, line = 0;
  for (std::size_t begin = start; begin < text.size(); ++line) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    const std::size_t first = text.find_first_not_of(' ', begin);
    const bool blank = first >= end;
    const bool comment = !blank && text[first] == '#';
    if (!blank && !comment && flow == 0)
      while (!blocks.empty() && blocks.back() > first - begin) blocks.pop_back();
    // (searches bounded by the line: a scan stays linear in the file's size)
    const auto lineBegin = text.begin() + std::ptrdiff_t(begin);
    const auto lineEnd = text.begin() + std::ptrdiff_t(end);
    const auto uncertain = [](char c) { return c == '#' || c == '\'' || c == '"' || c == '!'; };
    const std::size_t uncertainFrom =
        std::size_t(std::find_if(lineBegin, lineEnd, uncertain) - text.begin());
    const auto colon = std::find(std::make_reverse_iterator(lineEnd),
                                 std::make_reverse_iterator(lineBegin), ':');
    const bool colonAfter = colon.base() != lineBegin;
    const std::size_t lastColon = std::size_t(colon.base() - text.begin()) - 1;
    auto open = [&](std::size_t column) {
      if (blocks.empty() || column > blocks.back()) blocks.push_back(column);
      limit.check(int(blocks.size()) + flow, line + 1);
    };
    // Where the value being read may start: the line's first character, or just after
    // a '-' or ':' that may have opened a collection (at most as far right as OpenCV's).
    std::size_t from = first;
    for (std::size_t i = begin; i < end; ++i) {
      const char c = text[i];
      if (c == '[' || c == '{') {
        ++flow;
        limit.check(int(blocks.size()) + flow, line + 1);
      } else if ((c == ']' || c == '}') && i < uncertainFrom &&
                 (!colonAfter || i > lastColon)) {
        flow = std::max(0, flow - 1);
      }
      if (blank || comment) continue;
      const char before = i > begin ? text[i - 1] : ' ';
      if (c == '-' && (before == ' ' || before == '\t' || before == ':' || before == '-')) {
        open(i - begin);  // a block sequence: its column is the '-'
        from = i + 1;
      } else if (c == ':') {
        open(from - begin);  // a key, which starts at or after `from`
        from = i + 1;
      }
    }
    begin = end + 1;
  }
}

// YAML's stream layout. OpenCV's top-level loop assumes that a document's root
// collection ends at the end of the text or at a "..." line, skips three characters
// there, and then loops forever on a '-' that does not start "---" ("a: 1\n...\n-x",
// or " -x\n]\n-", whose root starts at column 1 and so ends early). So each document's
// root starts at column 0 as a block map or sequence, nothing follows "---" or "..." on
// their line, and a "..." is followed by "---", a directive or the end.
void checkYamlLayout(const std::string& text, std::size_t start, const std::string& source) {
  bool rootNext = true, endedDocument = false;
  int line = 0;
  for (std::size_t begin = start; begin < text.size(); ) {
    ++line;
    std::size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    const std::size_t first = text.find_first_not_of(" \r", begin);
    const bool content = first < end && text[first] != '#';
    const auto restIsBlank = [&](std::size_t from) {
      const std::size_t next = text.find_first_not_of(" \r", from);
      return next >= end || text[next] == '#';
    };
    const auto refuseLayout = [&](const char* what) {
      refuse(source, cv::format("has %s (line %d); expected a YAML map of parameters starting "
                                "at column 0, as LiFF writes",
                                what, line));
    };
    if (!content) {
    } else if (first == begin && startsWith(text, begin, "---")) {
      if (!restIsBlank(begin + 3)) refuseLayout("text after '---'");
      rootNext = true;
      endedDocument = false;
    } else if (first == begin && startsWith(text, begin, "...")) {
      if (!restIsBlank(begin + 3)) refuseLayout("text after '...'");
      endedDocument = true;
    } else if (first == begin && text[first] == '%' && (rootNext || endedDocument)) {
      // a directive
    } else if (endedDocument) {
      refuseLayout("text after '...' that does not start a document with '---'");
    } else if (rootNext) {
      if (first != begin) refuseLayout("a document that does not start at column 0");
      if (text[first] == '[' || text[first] == '{')
        refuseLayout("a document in flow style ([...] or {...})");
      if (text[first] == '!')  // (its root would start after the tag)
        refuseLayout("a document with a type tag");
      rootNext = false;
    }
    begin = end + 1;
  }
}

// XML: an element opens at '<' and a letter, digit or '_', closes at "</" or "/>";
// closers inside <!-- --> comments do not count.
void scanXml(const std::string& text, std::size_t start, const std::string& source) {
  const Depth limit(source);
  int depth = 0, line = 1;
  bool comment = false;
  for (std::size_t i = start; i < text.size(); ++i) {
    const char c = text[i];
    const unsigned char next = i + 1 < text.size() ? text[i + 1] : '\0';
    if (c == '\n') ++line;
    if (c == '<' && (std::isalnum(next) || next == '_')) limit.check(++depth, line);
    if (comment) {
      if (startsWith(text, i, "-->")) comment = false, i += 2;
    } else if (startsWith(text, i, "<!--")) {
      comment = true;
      i += 3;
    } else if ((c == '<' || c == '/') && next == (c == '<' ? '/' : '>')) {
      depth = std::max(0, depth - 1);
    }
  }
}

// OpenCV's parsers read an integer with (int)strtol, which wraps silently
// (4294967297 -> 1, 99999999999999999999999 -> -1): each integer parameter `key`
// written as an integer anywhere in `text` ("key: v", "\"key\": v", "<key>v") must
// fit an int. Its own range is Parameters::check's, on the value read.
void checkIntegerAsWritten(const std::string& text, const std::string& key,
                           const std::string& source) {
  const auto nameChar = [](char c) { return std::isalnum((unsigned char)c) || c == '_'; };
  for (std::size_t at = text.find(key); at != std::string::npos; at = text.find(key, at + 1)) {
    std::size_t i = at + key.size();
    if ((at > 0 && nameChar(text[at - 1])) || (i < text.size() && nameChar(text[i]))) continue;
    const bool xml = at > 0 && text[at - 1] == '<';
    if (!xml && i < text.size() && text[i] == '"') ++i;  // a JSON key's closing quote
    i = std::min(text.size(), text.find_first_not_of(" \t", i));
    if (i == text.size() || text[i] != (xml ? '>' : ':')) continue;
    i = std::min(text.size(), text.find_first_not_of(xml ? " \t\r\n" : " \t", i + 1));
    // (at most 40 characters: longer is beyond an int anyway, and the scan stays linear)
    std::size_t end = i;
    while (end < std::min(text.size(), i + 40) && !std::strchr(" \t\r\n,}]#<\"'", text[end]))
      ++end;
    const std::string token = text.substr(i, end - i);
    // An integer to OpenCV: a sign, digits, and no '.' or 'e' after them (else a real).
    const std::size_t digits = token.find_first_not_of("+-") == 1 ? 1 : 0;
    if (token.size() <= digits || !std::isdigit((unsigned char)token[digits])) continue;
    const std::size_t after = token.find_first_not_of("0123456789", digits);
    if (after != std::string::npos && (token[after] == '.' || token[after] == 'e')) continue;
    errno = 0;
    const long long value = std::strtoll(token.c_str(), nullptr, 0);
    if (errno == ERANGE || value < INT_MIN || value > INT_MAX)
      refuse(source, cv::format("sets %s = %s, which does not fit an int; expected an integer "
                                "in [%d, %d] (and in %s's range)",
                                key.c_str(), token.c_str(), INT_MIN, INT_MAX, key.c_str()));
  }
}

void checkIntegersAsWritten(const std::string& text, const std::string& source) {
#define LIFF_CHECK_INTEGER(Type, name, Name, initial, help) \
  if (!std::is_floating_point<Type>::value) checkIntegerAsWritten(text, #name, source);
  LIFF_PARAMETERS(LIFF_CHECK_INTEGER)
#undef LIFF_CHECK_INTEGER
}

}  // namespace

void checkParameterText(const std::string& text, const std::string& source) {
  if (text.size() > kMaxParameterFileBytes)
    refuse(source, cv::format("is larger than %zu bytes (1 MiB); expected a parameter file "
                              "(LiFF writes about 300 bytes)",
                              kMaxParameterFileBytes));
  const auto lineOf = [&](std::size_t at) {
    return 1 + int(std::count(text.begin(), text.begin() + at, '\n'));
  };
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '\0')
      refuse(source, cv::format("holds a NUL byte (line %d); expected text", lineOf(i)));
    if (text[i] == '\r' && (i + 1 == text.size() || text[i + 1] != '\n'))
      refuse(source, cv::format("holds a carriage return without a line feed (line %d); "
                                "expected lines ending in \\n or \\r\\n",
                                lineOf(i)));
  }
  // Base64 data (matrices; "$base64$", or YAML's !!binary tag) spans lines of any
  // content, which the scans below cannot follow; parameters are never base64.
  bool tagged = false;  // a '!' (a YAML tag) earlier on the line
  for (std::size_t i = 0; i < text.size(); ++i) {
    tagged = text[i] != '\n' && (tagged || text[i] == '!');
    if (tagged && startsWith(text, i, "binary"))
      refuse(source, cv::format("holds a binary (base64) value (line %d); expected parameters "
                                "as plain numbers",
                                lineOf(i)));
  }
  if (text.find("$base64$") != std::string::npos)
    refuse(source, cv::format("holds base64 data (line %d); expected parameters as plain numbers",
                              lineOf(text.find("$base64$"))));
  // The format as OpenCV tells it: from the first bytes after a UTF-8 byte order mark.
  const std::size_t start = startsWith(text, 0, "\xEF\xBB\xBF") ? 3 : 0;
  const Format format = startsWith(text, start, "{")       ? Format::Json
                        : startsWith(text, start, "<?xml") ? Format::Xml
                                                           : Format::Yaml;
  if (format == Format::Json) scanJson(text, start, source);
  if (format == Format::Xml) scanXml(text, start, source);
  if (format == Format::Yaml) {
    checkYamlLayout(text, start, source);
    scanYaml(text, start, source);
  }
}

cv::FileStorage openParameterText(const std::string& text, const std::string& source) {
  checkParameterText(text, source);
  cv::FileStorage fs;
  try {
    fs.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  } catch (const cv::Exception& e) {
    // OpenCV 4.6 swaps the message and the function of a parse error: show both, less
    // the document's first line, by which OpenCV names one in memory, in 300 bytes.
    std::string detail;
    for (const cv::String& part : {e.err, e.func}) {
      const std::size_t same = std::size_t(
          std::mismatch(part.begin(), part.end(), text.begin(), text.end()).first - part.begin());
      const bool named = same >= std::min<std::size_t>(16, text.size()) && same > 0;
      detail += (detail.empty() ? "" : " ") + (named ? part.substr(same) : part);
    }
    if (detail.size() > 300) detail = detail.substr(0, 300) + "...";
    refuse(source, "cannot be parsed (OpenCV: " + detail +
                       "); expected an OpenCV FileStorage document (YAML, JSON or XML)");
  }
  if (!fs.isOpened())
    refuse(source, "cannot be parsed; expected an OpenCV FileStorage document (YAML, JSON or XML)");
  checkIntegersAsWritten(text, source);
  return fs;
}

cv::FileStorage openParameterFile(const std::string& path) {
  std::error_code error;
  const auto status = std::filesystem::status(path, error);
  if (!std::filesystem::exists(status))
    CV_Error(cv::Error::StsBadArg, "LiFF: no parameter file '" + path + "'");
  if (!std::filesystem::is_regular_file(status))
    CV_Error(cv::Error::StsBadArg, "LiFF: parameter file '" + path +
                                       "' is not a regular file (a folder, FIFO, socket or "
                                       "device); expected a regular file");
  std::ifstream in(path, std::ios::binary);
  std::string text;
  if (in) {
    // One byte more than the limit is enough to refuse a larger file unread.
    text.resize(kMaxParameterFileBytes + 1);
    in.read(&text[0], std::streamsize(text.size()));
    text.resize(std::size_t(in.gcount()));
  }
  if (!in && !in.eof())
    CV_Error(cv::Error::StsBadArg, "LiFF: cannot read parameter file '" + path +
                                       "'; expected a readable file");
  return openParameterText(text, "parameter file '" + path + "'");
}

}  // namespace liff
