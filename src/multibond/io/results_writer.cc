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

void WriteFileAtomic(const std::string& path, const std::string& content) {
  const std::string tmp = path + ".partial";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error(fmt::format("cannot write '{}': {}", tmp, std::strerror(errno)));
    out << content;
    out.flush();
    if (!out) throw std::runtime_error(fmt::format("cannot write '{}': {}", tmp, std::strerror(errno)));
  }
  std::filesystem::rename(tmp, path);
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
  file_ = std::fopen(partial_.c_str(), "wb");
  if (!file_) throw std::runtime_error(fmt::format("cannot write '{}': {}", partial_, std::strerror(errno)));
  line_.clear();
  for (size_t i = 0; i < columns.size(); ++i) {
    if (i) line_ += ',';
    line_ += columns[i].Header();
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
  const bool ok = std::fflush(file_) == 0;
  std::fclose(file_);
  file_ = nullptr;
  if (!ok) throw std::runtime_error(fmt::format("cannot write '{}': {}", partial_, std::strerror(errno)));
  std::filesystem::rename(partial_, path_);
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
  if (io.method == Method::kBdf || io.method == Method::kAdams) {
    j["solver_stats"]["jacobian"] = summary.stats.sparse_jacobian ? "sparse" : "dense";
    j["solver_stats"]["evals_per_jacobian"] = summary.stats.evals_per_jacobian;
  }
  j["energy"] = {{"work", summary.energy_work}, {"stored", summary.energy_stored},
                 {"dissipated", summary.energy_dissipated}, {"residual", summary.energy_residual},
                 {"max_abs_residual", summary.max_abs_energy_residual}};
  return j;
}

}  // namespace multibond
