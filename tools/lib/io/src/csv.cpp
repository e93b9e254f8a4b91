#include "exoid/tools/csv.hpp"

#include <fstream>
#include <set>
#include <sstream>

#include "exoid/common/strict_number.hpp"

namespace exoid::tools {

namespace {
std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::string cell;
  std::stringstream ss(line);
  while (std::getline(ss, cell, ',')) {
    const size_t a = cell.find_first_not_of(" \t\r"), b = cell.find_last_not_of(" \t\r");
    out.push_back(a == std::string::npos ? std::string() : cell.substr(a, b - a + 1));
  }
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}
bool blank(const std::string& line) { return line.find_first_not_of(" \t\r") == std::string::npos; }
}  // namespace

int CsvTable::column(const std::string& name) const {
  for (size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return static_cast<int>(i);
  return -1;
}

bool readCsv(const std::string& path, CsvTable& table, std::string* error) {
  auto fail = [&](const std::string& msg) {
    if (error) *error = path + ": " + msg;
    return false;
  };
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail("cannot read file");
  table = CsvTable();
  std::string line;
  long line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    // A UTF-8 byte-order mark (spreadsheet exports) is not part of the first column's name.
    if (line_no == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);
    if (blank(line) || line[0] == '#') continue;
    if (table.header.empty()) {
      table.header = split(line);
      std::set<std::string> seen;
      for (const std::string& h : table.header) {
        if (h.empty()) return fail("line " + std::to_string(line_no) + ": empty column name in header");
        if (!seen.insert(h).second) return fail("duplicate column '" + h + "'");
      }
      continue;
    }
    const std::vector<std::string> cells = split(line);
    if (cells.size() != table.header.size())
      return fail("line " + std::to_string(line_no) + ": " + std::to_string(cells.size()) + " cells, header has " +
                  std::to_string(table.header.size()));
    std::vector<double> row(cells.size());
    for (size_t c = 0; c < cells.size(); ++c) {
      std::string why;
      if (!common::parseDouble(cells[c], row[c], &why))
        return fail("line " + std::to_string(line_no) + ", column " + std::to_string(c + 1) + " '" +
                    table.header[c] + "': " + common::quoteValue(cells[c]) + ": " + why);
    }
    table.rows.push_back(std::move(row));
    table.lines.push_back(line_no);
  }
  if (in.bad()) return fail("read error");
  if (table.header.empty()) return fail("no header row");
  if (table.rows.empty()) return fail("no data row after the header");
  return true;
}

AtomicCsvWriter::~AtomicCsvWriter() {
  if (f_) {
    std::fclose(f_);
    std::remove(tmp_.c_str());
  }
}

bool AtomicCsvWriter::open(const std::string& path, std::string* error) {
  path_ = path;
  tmp_ = path + ".tmp";
  f_ = std::fopen(tmp_.c_str(), "w");
  if (!f_ && error) *error = "cannot write '" + tmp_ + "'";
  return f_ != nullptr;
}

bool AtomicCsvWriter::commit(std::string* error) {
  const bool ok = f_ && std::fflush(f_) == 0 && !std::ferror(f_);
  if (f_) std::fclose(f_);
  f_ = nullptr;
  if (!ok || std::rename(tmp_.c_str(), path_.c_str()) != 0) {
    std::remove(tmp_.c_str());
    if (error) *error = "cannot write '" + path_ + "'";
    return false;
  }
  return true;
}

}  // namespace exoid::tools
