#pragma once
/// \file
/// results.h5: the results of a run as an HDF5 file, written through the HDF5 C library (serial).
/// Readable by h5py, MATLAB's h5read, Octave, HDFView, ...
///
/// - one dataset per column in the root group, named by the column's name (Hdf5Name in
///   io/result_names.h: `/` and `%` percent-encoded), 1-D, float64 little-endian, chunked (at most
///   65,536 values a chunk; with `compress`, shuffled and deflated at level kH5DeflateLevel); its
///   attributes: `unit` ("s", "N s", "-"), `name` (the column's name as in results.csv) and
///   `column` (its index in results.csv, 0 for `time`);
/// - attributes of the root group, from the run record (MakeRunRecord): `model` (the model file
///   as given), `model_name`, `model_sha256`, `version`, `status`, `message` (when the run stopped
///   early), `solver`, `rtol`, `atol`, `t_start`, `t_end`, `dt`, `t_reached`, `samples`, `columns`
///   (the dataset names in the order of results.csv) and `run_record` (the whole record as JSON).
///
/// Strings are variable-length UTF-8.

#include <string>

#include <nlohmann/json.hpp>

#include "multibond/io/column_store.h"

namespace multibond {

/// zlib's level for compressed datasets: 1, the fastest (results are doubles with full mantissas,
/// which higher levels hardly compress further).
inline constexpr unsigned kH5DeflateLevel = 1;

/// The dataset names of `columns` in results.h5 (Hdf5Name, unique).
std::vector<std::string> H5DatasetNames(const std::vector<Column>& columns);

/// Writes `results` and `record` to a new HDF5 file at `path` (replacing what is there). Throws
/// std::runtime_error "cannot write '<path>': <why>".
void WriteH5Results(const std::string& path, const ColumnStore& results, const nlohmann::json& record, bool compress);

}  // namespace multibond
