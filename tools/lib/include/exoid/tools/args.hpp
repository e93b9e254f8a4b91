#pragma once
// Minimal strict command-line parsing for exoid's binaries: "--name value" options and "--flag" switches
// declared up front; anything else is an error naming the argument.
#include <map>
#include <set>
#include <string>

namespace exoid::tools {

class Args {
 public:
  Args& option(const std::string& name, const std::string& default_value = "") {
    values_[name] = default_value;
    return *this;
  }
  Args& flag(const std::string& name) {
    flags_.insert(name);
    return *this;
  }
  /// Parses argv[first..argc). Returns false with *error on an unknown argument or a missing value.
  bool parse(int argc, char** argv, int first, std::string* error);
  const std::string& get(const std::string& name) const { return values_.at(name); }
  bool has(const std::string& name) const { return set_.count(name) > 0; }  ///< given on the command line
  /// Parses a floating-point option; false with *error if it is not a finite number.
  bool getDouble(const std::string& name, double& out, std::string* error) const;
  bool getInt(const std::string& name, long& out, std::string* error) const;

 private:
  std::map<std::string, std::string> values_;
  std::set<std::string> flags_, set_;
};

}  // namespace exoid::tools
