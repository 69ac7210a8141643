#include "multibond/io/h5_writer.h"

#include <hdf5.h>

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <unordered_set>
#include <vector>

#include <fmt/format.h>

#include "multibond/io/result_names.h"
#include "multibond/version.h"

namespace multibond {

namespace {

/// An HDF5 identifier, closed with its own function when it goes.
class Id {
 public:
  Id(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Id() {
    if (id_ >= 0) close_(id_);
  }
  Id(const Id&) = delete;
  Id& operator=(const Id&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }
  /// Closes now; false when closing failed (a file that could not be flushed).
  bool Close() {
    const herr_t r = id_ >= 0 ? close_(id_) : 0;
    id_ = -1;
    return r >= 0;
  }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

/// The innermost message of HDF5's error stack ("" when empty).
std::string LastHdf5Error() {
  std::string message;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_UPWARD,
      [](unsigned n, const H5E_error2_t* e, void* data) -> herr_t {
        if (n == 0 && e->desc) *static_cast<std::string*>(data) = e->desc;
        return 0;
      },
      &message);
  return message;
}

/// HDF5 prints its error stack to stderr by default; here a failure is an exception instead.
class QuietErrors {
 public:
  QuietErrors() {
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietErrors() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }
  QuietErrors(const QuietErrors&) = delete;
  QuietErrors& operator=(const QuietErrors&) = delete;

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

class Writer {
 public:
  explicit Writer(const std::string& path) : path_(path) {}

  [[noreturn]] void Fail(const std::string& what) const {
    const std::string why = LastHdf5Error();
    throw std::runtime_error(fmt::format("cannot write '{}': {}{}", path_, what, why.empty() ? "" : " (" + why + ")"));
  }
  void Check(herr_t r, const std::string& what) const {
    if (r < 0) Fail(what);
  }
  hid_t Checked(hid_t id, const std::string& what) const {
    if (id < 0) Fail(what);
    return id;
  }

  void StringAttribute(hid_t loc, const char* name, const std::string& value) const {
    Id type(Checked(H5Tcopy(H5T_C_S1), "a string type"), H5Tclose);
    Check(H5Tset_size(type.get(), H5T_VARIABLE), "a string type");
    Check(H5Tset_cset(type.get(), H5T_CSET_UTF8), "a string type");
    Id space(Checked(H5Screate(H5S_SCALAR), "a dataspace"), H5Sclose);
    Id attr(Checked(H5Acreate2(loc, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), fmt::format("the attribute '{}'", name)),
            H5Aclose);
    const std::string text = StoredText(value);
    const char* p = text.c_str();
    Check(H5Awrite(attr.get(), type.get(), &p), fmt::format("the attribute '{}'", name));
  }

  void StringListAttribute(hid_t loc, const char* name, const std::vector<std::string>& values) const {
    Id type(Checked(H5Tcopy(H5T_C_S1), "a string type"), H5Tclose);
    Check(H5Tset_size(type.get(), H5T_VARIABLE), "a string type");
    Check(H5Tset_cset(type.get(), H5T_CSET_UTF8), "a string type");
    const hsize_t dims[1] = {values.size()};
    Id space(Checked(H5Screate_simple(1, dims, nullptr), "a dataspace"), H5Sclose);
    Id attr(Checked(H5Acreate2(loc, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), fmt::format("the attribute '{}'", name)),
            H5Aclose);
    std::vector<std::string> texts;
    for (const std::string& v : values) texts.push_back(StoredText(v));
    std::vector<const char*> pointers;
    for (const std::string& t : texts) pointers.push_back(t.c_str());
    if (!pointers.empty()) Check(H5Awrite(attr.get(), type.get(), pointers.data()), fmt::format("the attribute '{}'", name));
  }

  template <class T>
  void NumberAttribute(hid_t loc, const char* name, T value) const {
    const hid_t file_type = std::is_floating_point_v<T> ? H5T_IEEE_F64LE : H5T_STD_I64LE;
    const hid_t memory_type = std::is_floating_point_v<T> ? H5T_NATIVE_DOUBLE : H5T_NATIVE_INT64;
    Id space(Checked(H5Screate(H5S_SCALAR), "a dataspace"), H5Sclose);
    Id attr(Checked(H5Acreate2(loc, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT), fmt::format("the attribute '{}'", name)),
            H5Aclose);
    using Stored = std::conditional_t<std::is_floating_point_v<T>, double, std::int64_t>;
    const Stored v = static_cast<Stored>(value);
    Check(H5Awrite(attr.get(), memory_type, &v), fmt::format("the attribute '{}'", name));
  }

 private:
  std::string path_;
};

/// The record's value at `pointer` as text ("" when absent); numbers as JSON writes them.
std::string RecordText(const nlohmann::json& record, const char* pointer) {
  const nlohmann::json::json_pointer p(pointer);
  if (!record.contains(p)) return "";
  const nlohmann::json& v = record.at(p);
  return v.is_string() ? v.get<std::string>() : v.dump();
}

double RecordNumber(const nlohmann::json& record, const char* pointer) {
  const nlohmann::json::json_pointer p(pointer);
  return record.contains(p) && record.at(p).is_number() ? record.at(p).get<double>() : 0.0;
}

}  // namespace

std::vector<std::string> H5DatasetNames(const std::vector<Column>& columns) {
  std::unordered_set<std::string> taken;
  std::vector<std::string> names;
  for (const Column& c : columns) {
    const std::string base = Hdf5Name(StoredText(c.name));
    std::string name = base;
    // Only when two names are the same after escaping bytes that are not UTF-8: "%%" appears in
    // no escaped name.
    for (int k = 2; taken.count(name); ++k) name = fmt::format("{}%%{}", base, k);
    taken.insert(name);
    names.push_back(std::move(name));
  }
  return names;
}

void WriteH5Results(const std::string& path, const ColumnStore& results, const nlohmann::json& record, bool compress) {
  const QuietErrors quiet;
  const Writer w(path);
  const std::vector<Column>& columns = results.columns();
  const std::vector<std::string> names = H5DatasetNames(columns);
  Id file(w.Checked(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), "HDF5 cannot create the file"), H5Fclose);
  Id lcpl(w.Checked(H5Pcreate(H5P_LINK_CREATE), "a property list"), H5Pclose);
  w.Check(H5Pset_char_encoding(lcpl.get(), H5T_CSET_UTF8), "a property list");

  const hsize_t rows = static_cast<hsize_t>(results.rows());
  const hsize_t chunk = std::clamp<hsize_t>(rows, 1, 65536);
  Id dcpl(w.Checked(H5Pcreate(H5P_DATASET_CREATE), "a property list"), H5Pclose);
  w.Check(H5Pset_chunk(dcpl.get(), 1, &chunk), "the chunk size");
  if (compress) {
    w.Check(H5Pset_shuffle(dcpl.get()), "the shuffle filter");
    w.Check(H5Pset_deflate(dcpl.get(), kH5DeflateLevel), "the deflate filter");
  }
  const hsize_t dims[1] = {rows}, max_dims[1] = {H5S_UNLIMITED};
  Id space(w.Checked(H5Screate_simple(1, dims, max_dims), "a dataspace"), H5Sclose);
  for (size_t c = 0; c < columns.size(); ++c) {
    const std::string what = fmt::format("the dataset '{}'", names[c]);
    Id ds(w.Checked(H5Dcreate2(file.get(), names[c].c_str(), H5T_IEEE_F64LE, space.get(), lcpl.get(), dcpl.get(), H5P_DEFAULT), what),
          H5Dclose);
    if (rows > 0) w.Check(H5Dwrite(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, results.values(c).data()), what);
    w.StringAttribute(ds.get(), "unit", columns[c].unit);
    w.StringAttribute(ds.get(), "name", columns[c].name);
    w.NumberAttribute(ds.get(), "column", static_cast<std::int64_t>(c));
    if (!ds.Close()) w.Fail(what);
  }

  const hid_t root = file.get();
  w.StringAttribute(root, "model", RecordText(record, "/model/file"));
  w.StringAttribute(root, "model_name", RecordText(record, "/model/name"));
  w.StringAttribute(root, "model_sha256", RecordText(record, "/model/sha256"));
  w.StringAttribute(root, "version", kVersion);
  w.StringAttribute(root, "status", RecordText(record, "/status"));
  if (record.contains("message")) w.StringAttribute(root, "message", RecordText(record, "/message"));
  w.StringAttribute(root, "solver", RecordText(record, "/options/solver"));
  for (const char* key : {"rtol", "atol", "t_start", "t_end", "dt"})
    w.NumberAttribute(root, key, RecordNumber(record, (std::string("/options/") + key).c_str()));
  w.NumberAttribute(root, "t_reached", RecordNumber(record, "/t_reached"));
  w.NumberAttribute(root, "samples", static_cast<std::int64_t>(results.rows()));
  w.StringListAttribute(root, "columns", names);
  w.StringAttribute(root, "run_record", record.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  if (!file.Close()) w.Fail("HDF5 cannot close the file");
}

}  // namespace multibond
