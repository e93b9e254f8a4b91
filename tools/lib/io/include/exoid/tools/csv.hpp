#pragma once
// Strict CSV for the offline tools: a header row, numeric cells only, every cell finite. Errors name the
// file, row and column. Writing goes to "<path>.tmp" and is renamed on commit, so a failed run leaves no
// partial output file.
#include <cstdio>
#include <string>
#include <vector>

namespace exoid::tools {

struct CsvTable {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;  ///< [rows][header.size()]
  std::vector<long> lines;                ///< [rows] each row's line in the file, as an editor counts (1 = first)
  /// Index of a column, -1 if absent.
  int column(const std::string& name) const;
};

/// Reads a numeric CSV. Lines starting with '#' and blank lines are skipped; a UTF-8 byte-order mark and CRLF
/// line ends are accepted; spaces around a cell are ignored. Every cell is one finite number
/// (common::parseDouble: subnormals such as 1e-320 are numbers). Fails (false, *error naming the file, line,
/// column and value) on an unreadable file, a missing or duplicated header name, no data row, a row with
/// the wrong number of cells, a cell that is not a number, NaN, Inf or too large for a double.
bool readCsv(const std::string& path, CsvTable& table, std::string* error);

/// Writes rows atomically: open() writes to path + ".tmp", commit() renames it onto path, and the
/// destructor removes the temporary file if commit() was not reached.
class AtomicCsvWriter {
 public:
  ~AtomicCsvWriter();
  bool open(const std::string& path, std::string* error);
  FILE* file() { return f_; }
  bool commit(std::string* error);

 private:
  std::string path_, tmp_;
  FILE* f_ = nullptr;
};

}  // namespace exoid::tools
