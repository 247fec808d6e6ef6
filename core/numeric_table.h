// Text tables of numbers: one row per line, white-space separated, every row with the same
// named columns; blank lines and lines starting with '#' are skipped. The shared reader of
// trajectory files (`t x y theta`) and relations files (`t1 t2 x y z roll pitch yaw`).
#ifndef HETSLAM_CORE_NUMERIC_TABLE_H_
#define HETSLAM_CORE_NUMERIC_TABLE_H_

#include <string>
#include <vector>

#include "core/status.h"

namespace hetslam {

struct NumericRow {
  std::vector<double> values;  // one per column, all finite
  int line_number = 0;
};

// Reads `path` into `rows` (replaced). Errors name the file and line: a missing file or a
// directory, a row with another number of fields ("expected 4 fields 'timestamp x y theta',
// found 3"), a field that is not a finite number ("x ('abc') is not a finite number"), a read
// error. On error `rows` is empty.
Status ReadNumericTable(const std::string& path, const std::vector<std::string>& column_names,
                        std::vector<NumericRow>* rows);

}  // namespace hetslam

#endif  // HETSLAM_CORE_NUMERIC_TABLE_H_
