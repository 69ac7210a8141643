#include "multibond/analysis/linear_files.h"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "multibond/io/plot_gnuplot.h"
#include "multibond/io/results_folder.h"
#include "multibond/io/safe_text.h"

namespace multibond::linear {

namespace {

/// Text for JSON: nlohmann refuses to write bytes that are not UTF-8.
nlohmann::json Names(const std::vector<std::string>& names) {
  nlohmann::json j = nlohmann::json::array();
  for (const std::string& n : names) j.push_back(ValidUtf8(n));
  return j;
}

nlohmann::json Rows(const Eigen::MatrixXd& m) {
  nlohmann::json j = nlohmann::json::array();
  if (m.size() == 0) return j;
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (Eigen::Index c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
    j.push_back(std::move(row));
  }
  return j;
}

nlohmann::json Pair(std::complex<double> z) { return nlohmann::json::array({z.real(), z.imag()}); }

/// Adds every key of `record` to `j`; none may be one of j's own.
void Merge(nlohmann::json& j, const nlohmann::json& record) {
  if (record.is_null()) return;
  if (!record.is_object()) throw std::invalid_argument("the record must be a JSON object");
  for (const auto& [key, value] : record.items()) {
    if (j.contains(key)) throw std::invalid_argument(fmt::format("the record's key '{}' is one of the file's own", MessageText(key)));
    j[key] = value;
  }
}

std::string Number(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "Inf" : "-Inf";
  return fmt::format("{:.17g}", v);
}

std::string MatlabMatrix(const std::string& name, const Eigen::MatrixXd& m) {
  if (m.size() == 0) return fmt::format("{} = zeros({}, {});\n", name, m.rows(), m.cols());
  std::string s = name + " = [";
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    if (r > 0) s += ";\n  ";
    for (Eigen::Index c = 0; c < m.cols(); ++c) {
      if (c > 0) s += ' ';
      s += Number(m(r, c));
    }
  }
  return s + "];\n";
}

std::string MatlabCell(const std::string& name, const std::vector<std::string>& items) {
  if (items.empty()) return name + " = cell(1, 0);\n";
  std::string s = name + " = {";
  for (size_t k = 0; k < items.size(); ++k) {
    if (k > 0) s += ", ";
    s += MatlabString(items[k]);
  }
  return s + "};\n";
}

/// A file name the scripts may use as it is.
void CheckPlainName(const std::string& name) {
  const bool ok = !name.empty() && name.size() <= 200 && name[0] != '.' && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
  });
  if (!ok) throw std::invalid_argument(fmt::format("'{}' is not a plain file name", MessageText(name)));
}

}  // namespace

nlohmann::json LinearJson(const LinearModel& m, const nlohmann::json& record) {
  if (m.A.rows() != m.A.cols()) throw std::invalid_argument(fmt::format("A is {}x{}, not square", m.A.rows(), m.A.cols()));
  nlohmann::json j = nlohmann::json::object();
  j["states"] = Names(m.states);
  j["inputs"] = Names(m.inputs);
  j["outputs"] = Names(m.outputs);
  j["A"] = Rows(m.A);
  j["B"] = Rows(m.B);
  j["C"] = Rows(m.C);
  j["D"] = Rows(m.D);
  j["at"] = m.at;
  nlohmann::json eig = nlohmann::json::array();
  if (m.A.size() != 0 && m.A.allFinite()) {
    const Eigen::VectorXcd values = m.A.eigenvalues();
    std::vector<std::complex<double>> v(values.data(), values.data() + values.size());
    std::sort(v.begin(), v.end(), [](std::complex<double> a, std::complex<double> b) {
      if (std::abs(a) != std::abs(b)) return std::abs(a) < std::abs(b);
      if (a.real() != b.real()) return a.real() < b.real();
      return a.imag() < b.imag();
    });
    for (std::complex<double> z : v) eig.push_back(Pair(z));
  }
  j["eigenvalues"] = std::move(eig);
  j["state_units"] = Names(m.state_units);
  j["input_units"] = Names(m.input_units);
  j["output_units"] = Names(m.output_units);
  j["steady"] = m.steady;
  j["notes"] = Names(m.notes);
  j["basis"] = Rows(m.basis);
  j["full_states"] = Names(m.full_states);
  nlohmann::json x0 = nlohmann::json::array();
  for (Eigen::Index i = 0; i < m.x0.size(); ++i) x0.push_back(m.x0(i));
  j["x0"] = std::move(x0);
  if (!record.is_object() || !record.contains("model")) j["model"] = ValidUtf8(m.model);
  Merge(j, record);
  return j;
}

std::string MatlabString(const std::string& s) {
  const std::string valid = ValidUtf8(s);  // control characters but line feed and tab are U+FFFD
  std::string out = "'";
  for (char c : valid) {
    if (c == '\'')
      out += "''";
    else if (c == '\n' || c == '\t')
      out += "\xEF\xBF\xBD";
    else
      out += c;
  }
  return out + "'";
}

std::string LinearOctaveScript(const LinearModel& m) {
  std::string s;
  s += "% The linear model dz/dt = A z + B u, y = C z + D u, written by multibond (see linear.json for\n";
  s += "% the operating point, the basis and the notes). Run it, or load it with `run linear.m`.\n";
  s += "model = " + MatlabString(m.model) + ";\n";
  s += "at = " + Number(m.at) + ";\n";
  s += MatlabCell("states", m.states);
  s += MatlabCell("state_units", m.state_units);
  s += MatlabCell("inputs", m.inputs);
  s += MatlabCell("input_units", m.input_units);
  s += MatlabCell("outputs", m.outputs);
  s += MatlabCell("output_units", m.output_units);
  s += MatlabMatrix("A", m.A);
  s += MatlabMatrix("B", m.B);
  s += MatlabMatrix("C", m.C);
  s += MatlabMatrix("D", m.D);
  return s;
}

nlohmann::json ModesJson(const std::vector<Mode>& modes, const LinearModel& m, const nlohmann::json& record) {
  nlohmann::json list = nlohmann::json::array();
  for (const Mode& mode : modes) {
    if (mode.shape.size() != static_cast<Eigen::Index>(m.states.size()))
      throw std::invalid_argument(fmt::format("a mode's shape has {} entries for {} states", mode.shape.size(), m.states.size()));
    if (!mode.motion.empty() && mode.motion.size() != m.motion_names.size())
      throw std::invalid_argument(fmt::format("a mode's motion has {} entries for {} motions", mode.motion.size(), m.motion_names.size()));
    nlohmann::json j = nlohmann::json::object();
    j["eigenvalue"] = Pair(mode.eigenvalue);
    j["frequency_hz"] = mode.frequency_hz;
    j["damped_frequency_hz"] = mode.damped_frequency_hz;
    j["damping_ratio"] = mode.damping_ratio;
    j["time_constant_s"] = std::isfinite(mode.time_constant_s) ? nlohmann::json(mode.time_constant_s) : nlohmann::json(nullptr);
    j["conjugate_pair"] = mode.conjugate_pair;
    j["stores_energy"] = mode.stores_energy;
    nlohmann::json part = nlohmann::json::object(), shape = nlohmann::json::object(), motion = nlohmann::json::object();
    for (const auto& [element, share] : mode.participation) part[ValidUtf8(element)] = share;
    for (size_t i = 0; i < m.states.size(); ++i) shape[ValidUtf8(m.states[i])] = Pair(mode.shape(static_cast<Eigen::Index>(i)));
    for (size_t i = 0; i < mode.motion.size(); ++i) motion[ValidUtf8(m.motion_names[i])] = Pair(mode.motion[i]);
    j["participation"] = std::move(part);
    j["shape"] = std::move(shape);
    j["motion"] = std::move(motion);
    list.push_back(std::move(j));
  }
  nlohmann::json out = {{"modes", std::move(list)}};
  Merge(out, record);
  return out;
}

std::string BodeCsv(const std::vector<BodePoint>& points) {
  std::string s = "frequency [Hz],magnitude [dB],phase [deg]\n";
  for (const BodePoint& p : points) s += fmt::format("{:.17g},{:.17g},{:.17g}\n", p.frequency_hz, p.magnitude_db, p.phase_deg);
  return s;
}

std::string BodeGnuplotScript(const std::string& csv_name, const std::string& figure_name, const std::string& title) {
  CheckPlainName(csv_name);
  CheckPlainName(figure_name);
  const std::string csv = GnuplotString(csv_name);
  std::string s;
  s += "# " + GnuplotComment(title) + "\n";
  s += "# Written by multibond. Run it again from the results folder:\n";
  s += "#   gnuplot plots/" + figure_name + ".gp\n";
  s += "# It reads " + csv_name + " and writes figures/" + figure_name + ".png and .svg.\n";
  s += "set encoding utf8\n";
  s += "set datafile separator \",\"\n";
  s += "set datafile columnheaders\n";
  s += "set style data lines\n";
  s += "set grid xtics mxtics ytics lc rgb \"#dddddd\"\n";
  s += "set border lc rgb \"#444444\"\n";
  s += "set logscale x 10\n";
  s += "set autoscale xfix\n";
  s += "set format x \"10^{%L}\"\n";
  s += "set lmargin 12\n";
  s += "do for [format in \"png svg\"] {\n";
  s += "  if (format eq \"png\") {\n";
  s += "    set terminal pngcairo size 1000,800 enhanced font \"DejaVu Sans,11\" background \"white\"\n";
  s += "  } else {\n";
  s += "    set terminal svg size 1000,800 dynamic enhanced font \"DejaVu Sans,11\" background \"white\"\n";
  s += "  }\n";
  s += fmt::format("  set output {}.\".\".format\n", GnuplotString("figures/" + figure_name));
  s += fmt::format("  set multiplot layout 2,1 title {} font \",15\"\n", GnuplotString(GnuplotLiteralText(title)));
  s += "  unset xlabel\n";
  s += "  set ylabel \"magnitude [dB]\"\n";
  s += fmt::format("  plot {} using 1:2 lw 1.5 lc rgb \"#1f77b4\" notitle\n", csv);
  s += "  set xlabel \"frequency [Hz]\"\n";
  s += "  set ylabel \"phase [deg]\"\n";
  s += fmt::format("  plot {} using 1:3 lw 1.5 lc rgb \"#d62728\" notitle\n", csv);
  s += "  unset multiplot\n";
  s += "  unset output\n";
  s += "}\n";
  return s;
}

std::vector<std::string> DrawBodePlot(const std::string& dir, const std::string& csv_name, const std::string& figure_name,
                                      const std::string& title, const std::string& gnuplot) {
  const std::string script = BodeGnuplotScript(csv_name, figure_name, title);
  const ResultsFolder folder(dir);
  struct stat st {};
  const Fd csv = folder.OpenInput(csv_name, std::uint64_t{1} << 30, nullptr, &st);
  if (csv.get() < 0) throw std::runtime_error(fmt::format("{} does not exist", MessageText(folder.PathOf(csv_name))));
  const Fd figures_dir = folder.OutputDir("figures"), plots_dir = folder.OutputDir("plots");
  const WorkFolder work(folder);
  work.AddInput(folder, csv_name, csv.get(), st);
  work.Write("plots/" + figure_name + ".gp", script);
  std::map<std::string, std::string> failures = RunGnuplot(work, plots_dir.get(), {figure_name}, gnuplot, 1);
  work.Publish("plots/" + figure_name + ".gp", plots_dir.get(), figure_name + ".gp");
  if (!failures.empty()) throw std::runtime_error(fmt::format("gnuplot failed on the Bode plot: {}", failures.begin()->second));
  std::vector<std::string> files;
  for (const char* ext : {".png", ".svg"}) {
    const std::string name = figure_name + ext;
    if (!IsNonEmptyRegularFile(work.fd(), "figures/" + name) || !work.Publish("figures/" + name, figures_dir.get(), name))
      throw std::runtime_error(fmt::format("gnuplot wrote no {}", MessageText(folder.PathOf("figures/" + name))));
    files.push_back(folder.PathOf("figures/" + name));
  }
  return files;
}

}  // namespace multibond::linear
