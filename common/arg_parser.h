// Minimal command-line parsing for semmapd and the semmap CLI: declared flags only (unknown
// flags are errors), "--name value" or "--name=value" ("-x value" for one-letter names), boolean
// switches, positional arguments.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/status.h"

namespace semmap {

class ArgParser {
 public:
  // A flag taking a value; `help` is printed by Usage().
  void AddFlag(const std::string& name, const std::string& value_name, const std::string& help);
  void AddSwitch(const std::string& name, const std::string& help);
  // Parses argv[first..argc). Positional arguments are kept in order.
  Status Parse(int argc, const char* const* argv, int first = 1);

  bool Has(const std::string& name) const;
  std::string Get(const std::string& name, const std::string& fallback = "") const;
  StatusOr<double> GetDouble(const std::string& name, double fallback) const;
  StatusOr<long long> GetInt(const std::string& name, long long fallback) const;
  // A flag whose value is "on" or "off".
  StatusOr<bool> GetOnOff(const std::string& name, bool fallback) const;
  // All values of a repeatable flag.
  std::vector<std::string> GetAll(const std::string& name) const;
  const std::vector<std::string>& positional() const { return positional_; }

  std::string Usage() const;  // one line per flag

 private:
  struct Spec {
    std::string value_name;  // empty for switches
    std::string help;
  };
  std::vector<std::string> order_;
  std::map<std::string, Spec> specs_;
  std::multimap<std::string, std::string> values_;
  std::vector<std::string> positional_;
};

}  // namespace semmap
