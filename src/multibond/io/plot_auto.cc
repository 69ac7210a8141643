#include "multibond/io/plot_auto.h"

#include <algorithm>
#include <cctype>
#include <map>
#include <set>

#include <fmt/format.h>

#include "multibond/io/safe_text.h"

namespace multibond {

namespace {

/// A part of a file name: letters, digits and '_' (every other byte, and each run of them, one '_').
std::string Slug(const std::string& text) {
  std::string out;
  for (char c : text) {
    const bool keep = std::isalnum(static_cast<unsigned char>(c)) != 0 && static_cast<unsigned char>(c) < 0x80;
    if (keep) out += c;
    else if (out.empty() || out.back() != '_') out += '_';
    if (out.size() >= 40) break;
  }
  return out;
}

/// The element of a column: its name up to the first dot, or "outputs" for a name without one.
std::string ElementOf(const std::string& name) {
  const size_t dot = name.find('.');
  return dot == std::string::npos || dot == 0 ? "outputs" : name.substr(0, dot);
}

/// A group of columns that becomes a figure (or several, when it has many).
struct Group {
  std::string element, unit;
  std::vector<std::string> columns;
};

/// A time panel of `columns`, each a curve with the rest of its name as the legend.
Panel ColumnsPanel(const std::string& element, const std::vector<std::string>& columns, char id) {
  Panel p;
  p.id = std::string(1, id);
  p.quantity = GnuplotLiteralText(element);
  for (size_t k = 0; k < columns.size(); ++k) {
    const std::string& c = columns[k];
    const std::string legend = c.size() > element.size() + 1 && c.compare(0, element.size() + 1, element + ".") == 0
                                   ? c.substr(element.size() + 1)
                                   : c;
    p.curves.push_back({{c}, GnuplotLiteralText(legend), PlotColors()[k % PlotColors().size()]});
  }
  return p;
}

}  // namespace

FigureList AutoFigures(const std::vector<std::string>& names, const std::vector<std::string>& units, size_t max_figures,
                       std::vector<std::string>& warnings) {
  FigureList list;
  // The groups, in the order of their first column; the energy account's columns apart.
  std::vector<Group> groups;
  std::map<std::pair<std::string, std::string>, size_t> index;
  std::vector<Group> energy;  // one per unit
  for (size_t c = 0; c < names.size() && c < units.size(); ++c) {
    if (names[c] == "time") continue;
    const std::string element = ElementOf(names[c]);
    if (element == "energy") {
      auto it = std::find_if(energy.begin(), energy.end(), [&](const Group& g) { return g.unit == units[c]; });
      if (it == energy.end()) it = energy.insert(energy.end(), Group{element, units[c], {}});
      it->columns.push_back(names[c]);
      continue;
    }
    const auto [it, fresh] = index.emplace(std::make_pair(element, units[c]), groups.size());
    if (fresh) groups.push_back({element, units[c], {}});
    groups[it->second].columns.push_back(names[c]);
  }

  std::set<std::string> used;
  auto unique = [&](std::string name) {
    if (!IsFigureName(name)) name = "c" + name;
    std::string candidate = name;
    for (int k = 2; !used.insert(candidate).second; ++k) candidate = fmt::format("{}-{}", name, k);
    return candidate;
  };
  size_t wanted = 0, left_out = 0;
  auto room = [&] { return list.figures.size() < max_figures; };

  if (!energy.empty()) {
    ++wanted;
    if (room()) {
      Figure f;
      f.name = unique("energy-account");
      f.caption = "Energy account: work, stored (kinetic, potential), dissipated; residual";
      f.shows = "work = kinetic + potential + dissipated, up to the residual (relative to the largest energy handled).";
      list.sections.push_back("Energy account");
      f.section = 0;
      for (const Group& g : energy) {
        for (size_t from = 0; from < g.columns.size() && f.panels.size() < 26; from += kMaxCurvesPerFigure) {
          const std::vector<std::string> part(g.columns.begin() + static_cast<long>(from),
                                              g.columns.begin() + static_cast<long>(std::min(g.columns.size(), from + kMaxCurvesPerFigure)));
          f.panels.push_back(ColumnsPanel("energy", part, static_cast<char>('a' + f.panels.size())));
        }
      }
      list.figures.push_back(std::move(f));
    } else {
      ++left_out;
    }
  }

  std::map<std::string, int> section_of;
  for (const Group& g : groups) {
    const size_t parts = (g.columns.size() + kMaxCurvesPerFigure - 1) / kMaxCurvesPerFigure;
    for (size_t part = 0; part < parts; ++part) {
      ++wanted;
      if (!room()) {
        ++left_out;
        continue;
      }
      if (!section_of.count(g.element)) {
        section_of[g.element] = static_cast<int>(list.sections.size());
        list.sections.push_back(GnuplotLiteralText(g.element));
      }
      const size_t from = part * kMaxCurvesPerFigure;
      const std::vector<std::string> columns(g.columns.begin() + static_cast<long>(from),
                                             g.columns.begin() + static_cast<long>(std::min(g.columns.size(), from + kMaxCurvesPerFigure)));
      Figure f;
      const std::string unit_slug = g.unit.empty() || g.unit == "-" ? "1" : Slug(g.unit);
      f.name = unique(Slug(g.element) + "-" + unit_slug + (parts > 1 ? fmt::format("-{}", part + 1) : ""));
      f.caption = fmt::format("{} [{}]{}", GnuplotLiteralText(g.element), GnuplotLiteralText(g.unit.empty() ? "-" : g.unit),
                              parts > 1 ? fmt::format(", part {} of {}", part + 1, parts) : "");
      f.section = section_of[g.element];
      f.panels.push_back(ColumnsPanel(g.element, columns, 'a'));
      list.figures.push_back(std::move(f));
    }
  }
  if (left_out > 0)
    warnings.push_back(fmt::format("{} of {} figures left out: at most {} are drawn (raise it with --max-figures N, or give a figure "
                                   "list with --figures FILE; docs/plots.md)",
                                   left_out, wanted, max_figures));
  return list;
}

}  // namespace multibond
