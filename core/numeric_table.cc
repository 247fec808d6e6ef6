#include "core/numeric_table.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <fstream>

#include "core/text_fields.h"
#include "glog/logging.h"

namespace hetslam {

Status ReadNumericTable(const std::string& path, const std::vector<std::string>& column_names,
                        std::vector<NumericRow>* rows) {
  CHECK(rows != nullptr) << "ReadNumericTable: rows is null";
  CHECK(!column_names.empty()) << "ReadNumericTable: no columns";
  rows->clear();
  struct stat info;
  if (stat(path.c_str(), &info) != 0) {
    return Status::Error("cannot open '" + path + "': " + std::strerror(errno));
  }
  if (S_ISDIR(info.st_mode)) return Status::Error("cannot open '" + path + "': Is a directory");
  std::ifstream in(path);
  if (!in) return Status::Error("cannot open '" + path + "': " + std::strerror(errno));

  std::string layout;
  for (const std::string& name : column_names) layout += (layout.empty() ? "" : " ") + name;
  const size_t num_columns = column_names.size();
  std::string line;
  std::vector<std::string> fields;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    text_fields::Split(line, &fields);
    if (fields.empty() || fields[0][0] == '#') continue;
    const std::string where = path + ":" + std::to_string(line_number) + ": ";
    if (fields.size() != num_columns) {
      rows->clear();
      return Status::Error(where + "expected " + std::to_string(num_columns) + " fields '" + layout +
                           "', found " + std::to_string(fields.size()));
    }
    NumericRow row;
    row.line_number = line_number;
    row.values.resize(num_columns);
    for (size_t k = 0; k < num_columns; ++k) {
      if (!text_fields::ParseFiniteDouble(fields[k], &row.values[k])) {
        rows->clear();
        return Status::Error(where + column_names[k] + " ('" + fields[k] + "') is not a finite number");
      }
    }
    rows->push_back(std::move(row));
  }
  if (in.bad()) {
    rows->clear();
    return Status::Error("error reading '" + path + "': " + std::strerror(errno));
  }
  return Status::Ok();
}

}  // namespace hetslam
