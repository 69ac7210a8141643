#include "multibond/io/results_writer.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <fmt/format.h>
#include <openssl/evp.h>

#include "multibond/version.h"

namespace multibond {

namespace {

/// Removes the temporary file `tmp` (it can be large, and nothing would ever read it) and throws
/// the error for `path`, the file the user asked for.
[[noreturn]] void Abandon(const std::string& tmp, const std::string& path, const std::string& why) {
  std::error_code ignored;
  std::filesystem::remove(tmp, ignored);
  throw std::runtime_error(fmt::format("cannot write '{}': {}", path, why));
}

/// Renames the complete `tmp` to `path`, or abandons it.
void Commit(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (!ec) return;
  // rename(2) says "Is a directory" without saying which of the two names is one.
  std::error_code ignored;
  Abandon(tmp, path, std::filesystem::is_directory(path, ignored) ? "it is a directory" : ec.message());
}

}  // namespace

void WriteFileAtomic(const std::string& path, const std::string& content) {
  const std::string tmp = path + ".partial";
  std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error(fmt::format("cannot write '{}': {}", tmp, std::strerror(errno)));
  errno = 0;
  out << content;
  out.close();  // flushes: a full disk shows here
  if (!out) Abandon(tmp, path, errno ? std::strerror(errno) : "write error");
  Commit(tmp, path);
}

std::string CsvCell(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string cell = "\"";
  for (char c : text) {
    if (c == '"') cell += '"';
    cell += c;
  }
  return cell + '"';
}

std::string Sha256Hex(const std::string& data) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  EVP_Digest(data.data(), data.size(), digest, &len, EVP_sha256(), nullptr);
  std::string hex;
  for (unsigned int i = 0; i < len; ++i) hex += fmt::format("{:02x}", digest[i]);
  return hex;
}

CsvWriter::CsvWriter(std::string path) : path_(std::move(path)), partial_(path_ + ".partial") {}

CsvWriter::~CsvWriter() {
  if (file_) std::fclose(file_);
}

void CsvWriter::OnStart(const std::vector<Column>& columns) {
  // Known now, it is reported before the run rather than after it (the rename would fail).
  std::error_code ignored;
  if (std::filesystem::is_directory(path_, ignored))
    throw std::runtime_error(fmt::format("cannot write '{}': it is a directory", path_));
  file_ = std::fopen(partial_.c_str(), "wb");
  if (!file_) throw std::runtime_error(fmt::format("cannot write '{}': {}", partial_, std::strerror(errno)));
  line_.clear();
  for (size_t i = 0; i < columns.size(); ++i) {
    if (i) line_ += ',';
    line_ += CsvCell(columns[i].Header());
  }
  line_ += '\n';
  std::fputs(line_.c_str(), file_);
}

void CsvWriter::OnSample(const std::vector<double>& row) {
  line_.clear();
  for (size_t i = 0; i < row.size(); ++i) {
    if (i) line_ += ',';
    // Shortest representation that reads back to the same double: exact and reproducible.
    fmt::format_to(std::back_inserter(line_), "{}", row[i]);
  }
  line_ += '\n';
  std::fputs(line_.c_str(), file_);
}

void CsvWriter::OnFinish(const RunSummary&) {
  if (!file_) return;
  // A row that could not be written (full disk) left the error flag set; the file lacks it.
  errno = 0;
  bool ok = std::fflush(file_) == 0 && !std::ferror(file_);
  ok = std::fclose(file_) == 0 && ok;
  const int err = errno;
  file_ = nullptr;
  if (!ok) Abandon(partial_, path_, err ? std::strerror(err) : "write error");
  Commit(partial_, path_);
}

nlohmann::json MakeRunRecord(const std::string& model_file, const std::string& model_text, const std::string& model_name,
                             const RunOptions& options, const RunSummary& summary, const std::vector<std::string>& command_line) {
  using nlohmann::json;
  const IntegratorOptions& io = options.integrator;
  json j;
  j["multibond_version"] = kVersion;
  j["command_line"] = command_line;
  j["model"] = {{"file", model_file}, {"name", model_name}, {"sha256", Sha256Hex(model_text)}};
  j["options"] = {{"t_start", options.t_start}, {"t_end", options.t_end}, {"dt", options.dt},
                  {"solver", MethodName(io.method)}, {"rtol", io.rtol}, {"atol", io.atol},
                  {"step", io.fixed_step}, {"max_step", io.max_step}, {"all_variables", options.all_variables},
                  {"projection", io.project}, {"jacobian", JacobianKindName(io.jacobian)}};
  j["status"] = RunStatusName(summary.status);
  if (!summary.message.empty()) j["message"] = summary.message;
  j["t_reached"] = summary.t_reached;
  j["samples"] = summary.samples;
  j["wall_seconds"] = summary.wall_seconds;
  j["solver_stats"] = {{"steps", summary.stats.steps}, {"rhs_evals", summary.stats.rhs_evals},
                       {"jac_evals", summary.stats.jac_evals}, {"linear_setups", summary.stats.linear_setups},
                       {"error_test_failures", summary.stats.error_test_failures},
                       {"nonlinear_failures", summary.stats.nonlinear_failures}, {"last_step", summary.stats.last_step}};
  if (UsesNewtonMatrix(io.method)) {
    j["solver_stats"]["jacobian"] = summary.stats.sparse_jacobian ? "sparse" : "dense";
    j["solver_stats"]["evals_per_jacobian"] = summary.stats.evals_per_jacobian;
  }
  j["energy"] = {{"work", summary.energy_work}, {"stored", summary.energy_stored},
                 {"dissipated", summary.energy_dissipated}, {"residual", summary.energy_residual},
                 {"max_abs_residual", summary.max_abs_energy_residual}};
  j["warnings"] = summary.warnings;
  return j;
}

}  // namespace multibond
