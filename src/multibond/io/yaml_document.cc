#include "multibond/io/yaml_document.h"

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <string_view>
#include <unordered_map>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>

#include "multibond/core/interrupt.h"
#include "multibond/core/regular_file.h"
#include "multibond/core/utf8.h"
#include "multibond/core/diagnostic_codes.h"
#include "multibond/io/yaml_bounds.h"

namespace multibond {

namespace {

Diagnostic FileSizeError(const std::string& file, std::uint64_t size, const InputLimits& limits) {
  Diagnostic d;
  d.where = {file, 1, 1};
  d.code = codes::kLimitFileSize;
  d.message = fmt::format("limit 'file-size' exceeded: the model is {} bytes long (at most {})", size, limits.file_bytes);
  d.hint = RaiseLimitHint("file-size", limits.file_bytes);
  return d;
}

[[noreturn]] void ThrowIo(const std::string& path, const std::string& code, const std::string& message, const std::string& hint) {
  Diagnostic d;
  d.where.file = path;
  d.code = code;  // "io.*": the CLI exits 74 for it, as for any file it cannot read
  d.message = message;
  d.hint = hint;
  throw ModelError(d);
}

}  // namespace

std::string ReadModelText(const std::string& path, const InputLimits& limits) {
  // O_NONBLOCK: opening a FIFO does not wait for a writer; it is refused below like a device.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0)
    ThrowIo(path, codes::kIoUnreadable, fmt::format("cannot open the model file: {}", std::strerror(errno)), "check the path and the file's permissions");
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0)
    ThrowIo(path, codes::kIoUnreadable, fmt::format("cannot read the model file: {}", std::strerror(errno)), "check the path and the file's permissions");
  if (!S_ISREG(st.st_mode)) {
    ThrowIo(path, codes::kIoNotRegular, fmt::format("cannot read the model file: it is {}", FileKindName(st.st_mode)),
            "give the path of a model file (.yaml)");
  }
  if (static_cast<std::uint64_t>(st.st_size) > limits.file_bytes) throw ModelError(FileSizeError(path, static_cast<std::uint64_t>(st.st_size), limits));
  // The file may grow while it is read: no more than the limit and one byte is read.
  std::string text;
  char buffer[1 << 16];
  while (text.size() <= limits.file_bytes) {
    const ssize_t n = ::read(fd, buffer, std::min<std::uint64_t>(sizeof buffer, limits.file_bytes + 1 - text.size()));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) ThrowIo(path, codes::kIoUnreadable, fmt::format("cannot read the model file: {}", std::strerror(errno)), "check the file");
    if (n == 0) break;
    text.append(buffer, static_cast<size_t>(n));
  }
  return text;
}

YAML::Node YamlDocument::Parse() {
  if (text_.size() > cx_.limits.file_bytes) throw ModelError(FileSizeError(cx_.file, text_.size(), cx_.limits));
  // Names, values and comments reach results, run.json and messages: the text must be UTF-8.
  if (const TextProblem t = FindTextProblem(text_); t.found()) {
    sink_.Error(codes::kTextEncoding, cx_.Location(t.offset), "", fmt::format("the model file is not UTF-8 text: {}", t.what),
                "save the file as UTF-8 (names are ASCII identifiers; other text may use any Unicode character)");
    sink_.ThrowIfErrors();
  }
  YAML::Node root;
  try {
    // One parse: the tree is built from the events as they are bounded (node count, aliases
    // expanded; depth; self-aliases), and no further than the first one out of bounds.
    const std::optional<std::vector<YAML::Node>> loaded = LoadYamlBounded(text_, cx_.file, cx_.limits, sink_);
    if (!loaded) sink_.ThrowIfErrors();
    const std::vector<YAML::Node>& documents = *loaded;
    // A second document (after '---') would be ignored by YAML::Load: a model file holds one.
    if (documents.size() > 1) {
      const YAML::Mark m = documents[1].Mark();
      sink_.Error(codes::kYamlStructure, {cx_.file, m.line >= 0 ? m.line + 1 : 0, m.column >= 0 ? m.column + 1 : 0}, "",
                  fmt::format("the file holds {} YAML documents; a model file is one", documents.size()),
                  "remove the '---' line (and what follows it, or merge it into the first document)");
      sink_.ThrowIfErrors();
    }
    if (!documents.empty()) root = documents.front();
  } catch (const YAML::Exception& e) {
    sink_.Add(ExplainSyntaxError(e));
    sink_.ThrowIfErrors();
  }
  if (!root.IsMap()) {
    sink_.Error(codes::kYamlStructure, {cx_.file, 1, 1}, "", "a model file must be a YAML mapping with at least 'elements' and 'bonds'",
                "start from an example in examples/");
    sink_.ThrowIfErrors();
  }
  CheckDuplicateKeys(root, "");
  sink_.ThrowIfErrors();
  return root;
}

/// yaml-cpp reports a syntax error where it noticed it, often a line after the cause (an
/// unclosed '{' is found at the next key). Where the cause can be told from the text, the
/// diagnostic says it: the bracket that is not closed, or closed by the wrong one, and the line
/// indented deeper than the block it is in.
Diagnostic YamlDocument::ExplainSyntaxError(const YAML::Exception& e) const {
  Diagnostic d;
  d.where = Loc(e.mark);
  d.message = "YAML syntax error: " + e.msg;
  d.hint = "check indentation, colons and brackets near this place";
  d.code = codes::kYamlSyntax;
  if (e.mark.line < 0) return d;
  // Offset of the error in the text, from its line and column.
  size_t at = 0;
  for (int line = 0; line < e.mark.line; ++line) {
    const size_t end = text_.find('\n', at);
    if (end == std::string::npos) return d;  // fewer lines than the mark says
    at = end + 1;
  }
  at = std::min(text_.size(), at + static_cast<size_t>(std::max(0, e.mark.column)));
  // The flow brackets still open at the error (quotes and comments skipped).
  struct Open {
    char c;
    size_t pos;
  };
  std::vector<Open> open;
  char quote = 0;
  for (size_t i = 0; i < at; ++i) {
    const char c = text_[i];
    if (quote) {
      if (c == quote && !(quote == '"' && i > 0 && text_[i - 1] == '\\')) quote = 0;
      else if (c == '\n') quote = 0;  // flow scalars do not span lines here; do not run away
      continue;
    }
    if (c == '"' || c == '\'') quote = c;
    else if (c == '#' && (i == 0 || text_[i - 1] == ' ' || text_[i - 1] == '\n')) i = std::min(at, text_.find('\n', i)) - 1;
    else if ((c == '{' || c == '[') && OpensFlow(i)) open.push_back({c, i});
    else if ((c == '}' || c == ']') && !open.empty()) open.pop_back();
  }
  auto location = [&](size_t pos) { return cx_.Location(pos); };
  const char here = at < text_.size() ? text_[at] : '\0';
  if (!open.empty() && (here == '}' || here == ']') && here != (open.back().c == '{' ? '}' : ']')) {
    d.details.push_back(fmt::format("the '{}' opened at {} is closed here by '{}'", open.back().c, location(open.back().pos).ToString(), here));
    d.hint = fmt::format("close it with '{}'", open.back().c == '{' ? '}' : ']');
  } else if (!open.empty() && e.msg.find("flow") != std::string::npos && e.msg.find("not found") != std::string::npos) {
    const Open& o = open.back();
    d.where = location(o.pos);
    d.details.push_back(fmt::format("the '{}' opened here is not closed (yaml-cpp noticed it at {})", o.c, Loc(e.mark).ToString()));
    d.hint = fmt::format("close it with '{}' (a flow collection may continue on the next lines, but must end)", o.c == '{' ? '}' : ']');
  } else if (e.msg.find("end of map not found") != std::string::npos || e.msg.find("end of sequence not found") != std::string::npos) {
    // A block collection broken by a line indented deeper than its siblings.
    auto indent = [&](size_t line_start) {
      size_t k = line_start;
      while (k < text_.size() && text_[k] == ' ') ++k;
      return k - line_start;
    };
    const size_t line_start = at == 0 ? 0 : text_.rfind('\n', at - 1) + 1;
    size_t prev = line_start;  // the previous line with content
    while (prev > 0) {
      prev = prev >= 2 ? text_.rfind('\n', prev - 2) + 1 : 0;
      const size_t k = prev + indent(prev);
      if (k < text_.size() && text_[k] != '\n' && text_[k] != '#') break;
    }
    const size_t prev_end = text_.find('\n', prev);
    const std::string prev_line = text_.substr(prev, prev_end == std::string::npos ? std::string::npos : prev_end - prev);
    const size_t last = prev_line.find_last_not_of(" \r");
    const bool opens_block = last != std::string::npos && prev_line[last] == ':';
    if (prev < line_start && indent(line_start) > indent(prev) && !opens_block) {
      d.where = location(line_start + indent(line_start));
      d.details.push_back(fmt::format("this line is indented by {} spaces, the one before it (line {}) by {}, and that one "
                                      "does not open a block", indent(line_start), location(prev).line, indent(prev)));
      d.hint = "indent entries of the same mapping or list equally";
    }
  }
  return d;
}

/// A '{' or '[' at text_[i] starts a flow collection when it starts a value: after ':', ',',
/// '-', another bracket or the line's indentation. Inside a plain scalar ("uses {x}") it is text.
bool YamlDocument::OpensFlow(size_t i) const {
  while (i > 0 && text_[i - 1] == ' ') --i;
  return i == 0 || std::string(":,-[{\n").find(text_[i - 1]) != std::string::npos;
}

/// A key given twice in one mapping: YAML forbids it, and yaml-cpp would keep the first value
/// and drop the other without a word. Checked over the whole document before it is read.
/// Element names (the keys of an 'elements' mapping) have their own check, with the same
/// information (ReadScope: "duplicate element name").
void YamlDocument::CheckDuplicateKeys(const YAML::Node& node, const std::string& path, bool element_names) {
  // Only lists and mappings are walked into, and a place's path is formatted only for them (or
  // for a diagnostic): a large model has hundreds of thousands of scalars.
  auto collection = [](const YAML::Node& n) { return n.IsSequence() || n.IsMap(); };
  if (collection(node)) {
    if ((++visits_ & 1023) == 0) ThrowIfStopRequested("loading the model");
    const YAML::Mark m = node.Mark();
    if (m.pos >= 0 && !walked_.insert(2 * static_cast<std::int64_t>(m.pos) + (element_names ? 1 : 0)).second) return;  // an alias of one checked
  }
  if (node.IsSequence()) {
    size_t i = 0;
    for (const auto& item : node) {
      if (collection(item)) CheckDuplicateKeys(item, fmt::format("{}[{}]", path, i), false);
      ++i;
    }
    return;
  }
  if (!node.IsMap()) return;
  // The keys so far, viewed in the tree's own strings, with where each stands.
  std::unordered_map<std::string_view, YAML::Mark> seen;
  seen.reserve(node.size());
  for (const auto& kv : node) {
    if (!kv.first.IsScalar()) continue;
    const std::string& key = kv.first.Scalar();
    auto where = [&] { return path.empty() ? key : path + "." + key; };
    if (key == "<<") {  // yaml-cpp reads a merge key as an ordinary key
      sink_.Error(codes::kYamlStructure, Loc(kv.first), path, "YAML merge keys ('<<: *anchor') are not supported",
                  "write the keys out (an anchor and alias of a whole value, '&a' and '*a', do work)");
      continue;
    }
    const auto [first, fresh] = seen.try_emplace(key, kv.first.Mark());
    if (!fresh && !element_names) {
      Diagnostic d;
      d.where = Loc(kv.first);
      d.element = where();
      d.message = fmt::format("duplicate key '{}': YAML allows a key once per mapping, and only the first value would be used", key);
      d.details.push_back("first given at " + Loc(first->second).ToString());
      d.hint = "remove one of the two, or merge them";
      d.code = codes::kYamlDuplicateKey;
      sink_.Add(d);
    }
    if (collection(kv.second)) CheckDuplicateKeys(kv.second, where(), key == "elements");
  }
}

}  // namespace multibond
