#include "multibond/io/mat_writer.h"

#include <matio.h>

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>

#include "multibond/io/result_names.h"
#include "multibond/version.h"

namespace multibond {

namespace {

// matio reports errors through a log function; the last message says why a write failed.
thread_local std::string last_matio_message;

void MatioLog(int /*level*/, char* message) { last_matio_message = message ? message : ""; }

struct MatVarDeleter {
  void operator()(matvar_t* v) const { Mat_VarFree(v); }
};
using MatVar = std::unique_ptr<matvar_t, MatVarDeleter>;

[[noreturn]] void Fail(const std::string& path, const std::string& what) {
  const std::string why = last_matio_message.empty() ? what : what + " (" + last_matio_message + ")";
  throw std::runtime_error(fmt::format("cannot write '{}': {}", path, why));
}

MatVar Checked(matvar_t* v) {
  if (!v) throw std::runtime_error("matio cannot create a variable" + (last_matio_message.empty() ? "" : ": " + last_matio_message));
  return MatVar(v);
}

/// UTF-16 code units of UTF-8 `text` (bytes that are not UTF-8 were escaped before).
std::vector<std::uint16_t> Utf16(const std::string& text) {
  std::vector<std::uint16_t> out;
  for (size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    std::uint32_t cp = c;
    size_t n = 1;
    if (c >= 0xF0) cp = c & 0x07, n = 4;
    else if (c >= 0xE0) cp = c & 0x0F, n = 3;
    else if (c >= 0xC0) cp = c & 0x1F, n = 2;
    if (i + n > text.size()) n = 1, cp = 0xFFFD;
    for (size_t k = 1; k < n; ++k) cp = (cp << 6) | (static_cast<unsigned char>(text[i + k]) & 0x3F);
    i += n;
    if (cp >= 0x10000) {
      cp -= 0x10000;
      out.push_back(static_cast<std::uint16_t>(0xD800 + (cp >> 10)));
      out.push_back(static_cast<std::uint16_t>(0xDC00 + (cp & 0x3FF)));
    } else {
      out.push_back(static_cast<std::uint16_t>(cp));
    }
  }
  return out;
}

MatVar Text(const char* name, const std::string& text) {
  std::vector<std::uint16_t> units = Utf16(StoredText(text));
  size_t dims[2] = {1, units.size()};
  if (units.empty()) dims[0] = 0;  // '' is 0x0 in MATLAB
  return Checked(Mat_VarCreate(name, MAT_C_CHAR, MAT_T_UINT16, 2, dims, units.data(), 0));
}

MatVar Number(const char* name, double value) {
  size_t dims[2] = {1, 1};
  return Checked(Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, &value, 0));
}

MatVar Logical(const char* name, bool value) {
  size_t dims[2] = {1, 1};
  std::uint8_t v = value ? 1 : 0;
  return Checked(Mat_VarCreate(name, MAT_C_UINT8, MAT_T_UINT8, 2, dims, &v, MAT_F_LOGICAL));
}

/// A struct whose fields are `names` (valid MATLAB names) with the given values.
MatVar Struct(const char* name, const std::vector<std::string>& names, std::vector<MatVar> values) {
  std::vector<const char*> fields;
  for (const std::string& n : names) fields.push_back(n.c_str());
  fields.push_back(nullptr);
  size_t dims[2] = {1, 1};
  MatVar s = Checked(Mat_VarCreateStruct2(name, 2, dims, fields.data()));
  for (size_t i = 0; i < names.size(); ++i) {
    // The struct owns the field from here (and frees a field it replaces).
    Mat_VarSetStructFieldByIndex(s.get(), i, 0, values[i].release());
  }
  return s;
}

MatVar FromJson(const char* name, const nlohmann::json& j) {
  using nlohmann::json;
  switch (j.type()) {
    case json::value_t::object: {
      std::vector<std::string> keys;
      std::vector<MatVar> values;
      for (const auto& [key, value] : j.items()) keys.push_back(key);
      const std::vector<std::string> fields = MatlabNames(keys);
      for (size_t i = 0; i < keys.size(); ++i) values.push_back(FromJson(fields[i].c_str(), j.at(keys[i])));
      return Struct(name, fields, std::move(values));
    }
    case json::value_t::array: {
      bool numbers = !j.empty();
      for (const json& e : j) numbers = numbers && e.is_number();
      if (numbers) {
        std::vector<double> v;
        for (const json& e : j) v.push_back(e.get<double>());
        size_t dims[2] = {1, v.size()};
        return Checked(Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, v.data(), 0));
      }
      size_t dims[2] = {1, j.size()};
      MatVar cell = Checked(Mat_VarCreate(name, MAT_C_CELL, MAT_T_CELL, 2, dims, nullptr, 0));
      int k = 0;
      for (const json& e : j) Mat_VarSetCell(cell.get(), k++, FromJson(nullptr, e).release());
      return cell;
    }
    case json::value_t::string: return Text(name, j.get<std::string>());
    case json::value_t::boolean: return Logical(name, j.get<bool>());
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: return Number(name, j.get<double>());
    default: {
      size_t dims[2] = {0, 0};
      return Checked(Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, nullptr, 0));
    }
  }
}

struct MatFileCloser {
  void operator()(mat_t* m) const { Mat_Close(m); }
};

}  // namespace

std::vector<std::string> MatVariableNames(const std::vector<Column>& columns) {
  std::vector<std::string> names;
  for (const Column& c : columns) names.push_back(c.name);
  // The first column is time (its name is "time"); the file's own variables are kept free.
  return MatlabNames(names, {"units", "columns", "meta"});
}

void WriteMatResults(const std::string& path, const ColumnStore& results, const nlohmann::json& record, bool compress) {
  Mat_LogInitFunc("multibond", MatioLog);
  last_matio_message.clear();
  const std::vector<Column>& columns = results.columns();
  const std::vector<std::string> names = MatVariableNames(columns);
  const std::string header = fmt::format("MATLAB 5.0 MAT-file, written by multibond {}", kVersion);
  std::unique_ptr<mat_t, MatFileCloser> mat(Mat_CreateVer(path.c_str(), header.c_str(), MAT_FT_MAT5));
  if (!mat) Fail(path, "matio cannot create the file");
  try {
    const auto write = [&](const MatVar& v, const std::string& what) {
      if (Mat_VarWrite(mat.get(), v.get(), compress ? MAT_COMPRESSION_ZLIB : MAT_COMPRESSION_NONE) != 0) Fail(path, "matio cannot write " + what);
    };
    for (size_t c = 0; c < columns.size(); ++c) {
      size_t dims[2] = {static_cast<size_t>(results.rows()), 1};
      // The column's values are written from where they are: no copy.
      auto* data = const_cast<double*>(results.values(c).data());
      write(Checked(Mat_VarCreate(names[c].c_str(), MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, data, MAT_F_DONT_COPY_DATA)),
            "the column " + names[c]);
    }
    std::vector<MatVar> units, originals;
    for (size_t c = 0; c < columns.size(); ++c) {
      units.push_back(Text(names[c].c_str(), columns[c].unit));
      originals.push_back(Text(names[c].c_str(), columns[c].name));
    }
    write(Struct("units", names, std::move(units)), "units");
    write(Struct("columns", names, std::move(originals)), "columns");
    write(FromJson("meta", record), "meta");
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    if (what.rfind("cannot write", 0) == 0) throw;
    Fail(path, what);
  }
  if (Mat_Close(mat.release()) != 0) Fail(path, "matio cannot close the file");
}

}  // namespace multibond
