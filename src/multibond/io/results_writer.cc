#include "multibond/io/results_writer.h"

#include <stdexcept>

#include <fmt/compile.h>
#include <fmt/format.h>

#include "multibond/core/sha256.h"
#include "multibond/core/utf8.h"
#include "multibond/version.h"

namespace multibond {

std::string CsvCell(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string cell = "\"";
  for (char c : text) {
    if (c == '"') cell += '"';
    cell += c;
  }
  return cell + '"';
}

CsvWriter::CsvWriter(std::string path, bool publish) : path_(std::move(path)), publish_(publish) {}

void CsvWriter::OnStart(const std::vector<Column>& columns) {
  file_ = std::make_unique<AtomicFile>(path_);  // a folder in the way is reported before the run
  line_.clear();
  for (size_t i = 0; i < columns.size(); ++i) {
    if (i) line_ += ',';
    line_ += CsvCell(columns[i].Header());
  }
  line_ += '\n';
  file_->Write(line_);
}

void CsvWriter::OnSample(const std::vector<double>& row) {
  // Shortest representation that reads back to the same double ("{}": exact and reproducible),
  // formatted by a compiled format straight into a buffer of the row's largest size (a double
  // takes at most 24 characters, "-2.2250738585072014e-308"), not through a growing string.
  constexpr size_t kMaxCell = 25;  // the longest double and its separator
  line_.resize(row.size() * kMaxCell + 1);
  char* const begin = line_.data();
  char* p = begin;
  for (size_t i = 0; i < row.size(); ++i) {
    if (i) *p++ = ',';
    p = fmt::format_to(p, FMT_COMPILE("{}"), row[i]);
  }
  *p++ = '\n';
  file_->Write(std::string_view(begin, static_cast<size_t>(p - begin)));
}

void CsvWriter::OnFinish(const RunSummary&) {
  if (!file_) return;
  file_->Finish();  // a row that could not be written (full disk) is said here
  if (publish_) file_->Publish();
}

std::uint64_t CsvWriter::bytes() const { return file_ ? file_->bytes() : 0; }
std::string CsvWriter::sha256() const { return file_ ? file_->sha256() : std::string(); }
void CsvWriter::Publish() {
  if (file_) file_->Publish();
}

nlohmann::json MakeRunRecord(const std::string& model_file, const std::string& model_text, const std::string& model_name,
                             const RunOptions& options, const RunSummary& summary, const std::vector<std::string>& command_line) {
  using nlohmann::json;
  const IntegratorOptions& io = options.integrator;
  json j;
  j["multibond_version"] = kVersion;
  // Paths and arguments are bytes: what is not UTF-8 is recorded escaped (\xNN), recoverably.
  std::vector<std::string> command;
  for (const std::string& a : command_line) command.push_back(EscapeInvalidUtf8(a));
  j["command_line"] = command;
  j["model"] = {{"file", EscapeInvalidUtf8(model_file)}, {"name", EscapeInvalidUtf8(model_name)}, {"sha256", Sha256Hex(model_text)}};
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
  // Events (docs/events.md): how many of each kind; the log itself is events.csv.
  long events = 0;
  json kinds = json::object();
  for (const auto& [kind, count] : summary.event_counts) kinds[kind] = count, events += count;
  j["events"] = {{"count", events}, {"by_kind", kinds}};
  j["options"]["event_rest_time"] = options.event_rest_time;
  j["options"]["max_events_per_second"] = options.max_events_per_second;
  return j;
}

nlohmann::json DataFileRecord(const std::string& name, std::uint64_t bytes, const std::string& sha256) {
  return {{"file", name}, {"bytes", bytes}, {"sha256", sha256}};
}

std::string DumpRecord(const nlohmann::json& record) {
  return record.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace multibond
