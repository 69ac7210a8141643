#pragma once
/// \file
/// results.mat: the results of a run as a MATLAB file (MAT version 5; with `compress`, each
/// variable compressed with zlib, as MATLAB's own `save` does), written through matio. Loads in MATLAB, Octave (`load`) and SciPy
/// (`scipy.io.loadmat`). Variables:
///
/// - one double column vector per result column, named by MatlabNames (io/result_names.h):
///   `time`, `mass_p`, `A_omega_z`, ...;
/// - `units`: a struct with a field per column variable, its unit ("s", "N s", "-");
/// - `columns`: a struct with a field per column variable, the column's name as in results.csv
///   ("A.omega.z"), so that a renamed column can be told;
/// - `meta`: the run record (what run.json holds, see MakeRunRecord) as a struct: objects become
///   structs (keys made MATLAB names the same way), strings char arrays, numbers doubles, true and
///   false logicals, lists of numbers row vectors, other lists cell arrays, null an empty [].
///
/// Text is stored as UTF-16 characters (MATLAB's own; Octave converts them to UTF-8), so any name
/// or unit survives; the variable and field names are ASCII. SciPy decodes such characters with
/// the system codec unless given `uint16_codec='utf-16-le'`.

#include <string>

#include <nlohmann/json.hpp>

#include "multibond/io/column_store.h"

namespace multibond {

/// The MATLAB variable names of `columns` in results.mat (time, then the rest, unique, none of
/// units, columns, meta).
std::vector<std::string> MatVariableNames(const std::vector<Column>& columns);

/// Writes `results` and `record` to a new MAT file at `path` (replacing what is there). Throws
/// std::runtime_error "cannot write '<path>': <why>".
void WriteMatResults(const std::string& path, const ColumnStore& results, const nlohmann::json& record, bool compress);

}  // namespace multibond
