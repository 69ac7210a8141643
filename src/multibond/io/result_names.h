#pragma once
/// \file
/// Names of result columns in the binary formats. Column names come from model files (untrusted):
/// whatever they hold, these functions give names the format accepts, and distinct columns get
/// distinct names.
///
/// MATLAB (results.mat): a variable name is a letter, then letters, digits and `_`, at most 63
/// characters (namelengthmax). A column's name is made one by replacing every other character by
/// `_` (one `_` per character, a multi-byte UTF-8 character or a byte that is not UTF-8 alike:
/// "A.omega.z" -> "A_omega_z"), putting `x` before a name that does not start with a letter ("_q"
/// -> "x_q", "" -> "x") and cutting it at 63 characters. A name that is taken (by an earlier
/// column, by a MATLAB keyword such as `end`, or by one of `reserved`: the file's own variables)
/// gets `_2`, `_3`, ... (cut so that the whole stays within 63 characters).
///
/// HDF5 (results.h5): a link name may hold any character but `/`, and cannot be "." or empty.
/// `%` is written `%25` and `/` is written `%2F`, as in a URL; "." is written `%2E` and the empty
/// name `%`. The mapping is one-to-one, so distinct columns keep distinct names, and reversible.

#include <string>
#include <vector>

namespace multibond {

/// The MATLAB name of each of `names`, in order: valid, unique, and none of `reserved`.
std::vector<std::string> MatlabNames(const std::vector<std::string>& names, const std::vector<std::string>& reserved = {});

/// True for a valid MATLAB variable or field name (not a keyword).
bool IsMatlabName(const std::string& name);

/// The HDF5 link name of a column (see above).
std::string Hdf5Name(const std::string& name);

/// Text for a format that stores C strings: bytes that are not UTF-8 written `\xNN` (as run.json
/// does) and NUL written `\x00`.
std::string StoredText(const std::string& text);

}  // namespace multibond
