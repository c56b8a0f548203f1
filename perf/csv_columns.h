// ReadCsvColumns: a benchmark CSV (a header line of column names, then rows
// of numbers) as one vector per column, for the perf/ plot tools.
//
// THREAD SAFETY: pure function. ALLOCATION: the file's numbers.
#pragma once

#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace graphslam::perf {

// False when the file is missing or empty. Empty lines are skipped.
inline bool ReadCsvColumns(const char* path, std::map<std::string, std::vector<double>>* columns,
                           int* rows) {
  std::ifstream in(path);
  std::string line;
  if (!std::getline(in, line)) return false;
  std::vector<std::string> header;
  {
    std::stringstream fields(line);
    for (std::string field; std::getline(fields, field, ',');) header.push_back(field);
  }
  *rows = 0;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::stringstream fields(line);
    size_t i = 0;
    for (std::string field; std::getline(fields, field, ',') && i < header.size(); ++i)
      (*columns)[header[i]].push_back(std::atof(field.c_str()));
    ++*rows;
  }
  return true;
}

}  // namespace graphslam::perf
