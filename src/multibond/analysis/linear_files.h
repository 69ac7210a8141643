#pragma once
/// \file
/// The files of the linear analysis commands, as text (the CLI writes them atomically), and the
/// Bode plot drawn by gnuplot:
///
///     linear.json   the linear model: states, inputs, outputs, A, B, C, D, at, eigenvalues (these
///                   key names are a contract), units, basis, the operating point, notes, and the
///                   caller's record (model, version, options)
///     linear.m      the same for MATLAB/Octave: A, B, C, D, states, inputs, outputs
///     modes.json    {"modes": [...]}, one entry per mode (modes.h)
///     bode.csv      frequency [Hz], magnitude [dB], phase [deg]
///
/// Names and units come from model files anyone may write: in linear.m every text is an escaped
/// single-quoted string literal; in the gnuplot script every text is an escaped gnuplot string
/// (io/safe_text.h).

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "multibond/analysis/bode.h"
#include "multibond/analysis/linear_model.h"
#include "multibond/analysis/modes.h"

namespace multibond::linear {

/// linear.json: keys `states`, `inputs`, `outputs` (lists of names), `A`, `B`, `C`, `D` (lists of
/// rows; a matrix without entries, e.g. B of a model without inputs, is the empty list: the
/// sizes are those of the name lists), `at` [s], `eigenvalues` (every eigenvalue of A as [re, im],
/// sorted by modulus, then real part, then imaginary part; none when A has a value that is not
/// finite), `state_units`, `input_units`,
/// `output_units`, `steady`, `notes`, `basis` (rows: full_states, columns: states), `full_states`,
/// `x0`, and every key of `record` (an object, or null for none). `model` is the model's name
/// unless `record` has its own `model`. Throws std::invalid_argument when `record` is not an
/// object or has any other of these keys, or when A is not square.
/// Doubles keep every digit (a value that is not finite is null).
nlohmann::json LinearJson(const LinearModel& model, const nlohmann::json& record = nlohmann::json::object());

/// linear.m, a MATLAB/Octave script that defines A, B, C, D (each value written with 17
/// significant digits; a matrix without entries as zeros(r, c)), the cell arrays of char
/// states, inputs, outputs and their units (state_units, input_units, output_units), the model
/// name `model` and the time `at`. Text is made a single-quoted literal by MatlabString.
std::string LinearOctaveScript(const LinearModel& model);

/// A MATLAB/Octave single-quoted char literal of `s`, quotes included: ' is written ''; line
/// breaks, other control characters and bytes that are not UTF-8 become U+FFFD, so that no text
/// can end the literal or the line.
std::string MatlabString(const std::string& s);

/// modes.json: {"modes": [{"eigenvalue": [re, im], "frequency_hz", "damping_ratio",
/// "time_constant_s" (null when infinite), "damped_frequency_hz", "conjugate_pair",
/// "stores_energy", "participation": {element: share}, "shape": {state: [re, im]},
/// "motion": {name: [re, im]}}, ...]} plus every key of `record` (as LinearJson; it may not be
/// "modes"). `model` gives the names of the states and motions (the model the modes came from).
/// Throws std::invalid_argument when a mode's shape or motion does not match the model's names.
nlohmann::json ModesJson(const std::vector<Mode>& modes, const LinearModel& model,
                         const nlohmann::json& record = nlohmann::json::object());

/// bode.csv: the header `frequency [Hz],magnitude [dB],phase [deg]`, then one row per point,
/// each value with 17 significant digits.
std::string BodeCsv(const std::vector<BodePoint>& points);

/// The gnuplot script of a Bode plot: magnitude [dB] above phase [deg], against the frequency
/// [Hz] on a log axis, read from `csv_name` (as BodeCsv writes it) in gnuplot's working folder;
/// it writes figures/<figure_name>.png and .svg there. `title` (which may name elements) is shown
/// as it is, through the escaping of io/safe_text.h. Throws std::invalid_argument when a file
/// name is not a plain name (letters, digits, '.', '_', '-'; not starting with '.').
std::string BodeGnuplotScript(const std::string& csv_name, const std::string& figure_name, const std::string& title);

/// Draws the Bode plot of `dir`/`csv_name` (a regular file, not a link, written before) as
/// `dir`/figures/<figure_name>.png and .svg, keeping its script as `dir`/plots/<figure_name>.gp,
/// the way `plot` draws (io/plots.h): gnuplot runs without a shell in a private work folder inside
/// `dir` and the files are renamed into place. Returns the pictures written; throws
/// std::runtime_error when gnuplot cannot be run or fails, or a file cannot be read or written.
std::vector<std::string> DrawBodePlot(const std::string& dir, const std::string& csv_name, const std::string& figure_name,
                                      const std::string& title, const std::string& gnuplot = "gnuplot");

}  // namespace multibond::linear
