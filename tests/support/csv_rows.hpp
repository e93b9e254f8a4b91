#pragma once
// A CSV the tools write, read as rows of header name -> cell text (cells may be text, e.g. wearer.csv's link names;
// exoid::tools::readCsv is for numeric tables). A trailing comma is an empty last cell.
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace exoid::test {

inline std::vector<std::map<std::string, std::string>> readCsvRows(const std::string& path) {
  auto split = [](const std::string& line) {
    std::vector<std::string> out;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) out.push_back(cell);
    if (!line.empty() && line.back() == ',') out.emplace_back();
    return out;
  };
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> head;
  std::vector<std::map<std::string, std::string>> rows;
  if (std::getline(in, line)) head = split(line);
  while (std::getline(in, line)) {
    const std::vector<std::string> cells = split(line);
    std::map<std::string, std::string> row;
    for (size_t i = 0; i < head.size() && i < cells.size(); ++i) row[head[i]] = cells[i];
    rows.push_back(row);
  }
  return rows;
}

}  // namespace exoid::test
