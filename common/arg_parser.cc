#include "common/arg_parser.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace semmap {

void ArgParser::AddFlag(const std::string& name, const std::string& value_name,
                        const std::string& help) {
  order_.push_back(name);
  specs_[name] = Spec{value_name.empty() ? "VALUE" : value_name, help};
}

void ArgParser::AddSwitch(const std::string& name, const std::string& help) {
  order_.push_back(name);
  specs_[name] = Spec{"", help};
}

Status ArgParser::Parse(int argc, const char* const* argv, int first) {
  bool only_positional = false;
  for (int i = first; i < argc; ++i) {
    std::string arg = argv[i];
    // Single-letter flags are written "-o"; longer ones "--name".
    const bool short_flag =
        arg.size() == 2 && arg[0] == '-' && std::isalpha(static_cast<unsigned char>(arg[1]));
    if (only_positional || (!short_flag && (arg.size() < 3 || arg.rfind("--", 0) != 0))) {
      if (arg == "--" && !only_positional) {
        only_positional = true;
        continue;
      }
      positional_.push_back(arg);
      continue;
    }
    std::string name = short_flag ? arg.substr(1) : arg.substr(2);
    std::optional<std::string> value;
    if (const size_t eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
    }
    auto spec = specs_.find(name);
    if (spec == specs_.end() || short_flag != (name.size() == 1)) {
      return InvalidArgumentError("unknown option " + arg);
    }
    if (spec->second.value_name.empty()) {
      if (value) return InvalidArgumentError("--" + name + " takes no value");
      values_.emplace(name, "true");
      continue;
    }
    if (!value) {
      if (i + 1 >= argc) return InvalidArgumentError("--" + name + " needs a value");
      value = argv[++i];
    }
    values_.emplace(name, *value);
  }
  return OkStatus();
}

bool ArgParser::Has(const std::string& name) const { return values_.count(name) > 0; }

std::string ArgParser::Get(const std::string& name, const std::string& fallback) const {
  auto range = values_.equal_range(name);
  if (range.first == range.second) return fallback;
  return std::prev(range.second)->second;  // the last occurrence wins
}

std::vector<std::string> ArgParser::GetAll(const std::string& name) const {
  std::vector<std::string> out;
  auto range = values_.equal_range(name);
  for (auto it = range.first; it != range.second; ++it) out.push_back(it->second);
  return out;
}

StatusOr<double> ArgParser::GetDouble(const std::string& name, double fallback) const {
  if (!Has(name)) return fallback;
  const std::string text = Get(name);
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno != 0 || !std::isfinite(v)) {
    return InvalidArgumentError("--" + name + " expects a number, got '" + text + "'");
  }
  return v;
}

StatusOr<bool> ArgParser::GetOnOff(const std::string& name, bool fallback) const {
  if (!Has(name)) return fallback;
  const std::string text = Get(name);
  if (text != "on" && text != "off") {
    return InvalidArgumentError("--" + name + " must be on or off, got '" + text + "'");
  }
  return text == "on";
}

StatusOr<long long> ArgParser::GetInt(const std::string& name, long long fallback) const {
  if (!Has(name)) return fallback;
  const std::string text = Get(name);
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno != 0) {
    return InvalidArgumentError("--" + name + " expects an integer, got '" + text + "'");
  }
  return v;
}

std::string ArgParser::Usage() const {
  std::string out;
  for (const std::string& name : order_) {
    const Spec& spec = specs_.at(name);
    std::string left = std::string(name.size() == 1 ? "  -" : "  --") + name +
                       (spec.value_name.empty() ? "" : " " + spec.value_name);
    if (left.size() < 28)
      left.resize(28, ' ');
    else
      left += "  ";
    out += left + spec.help + "\n";
  }
  return out;
}

}  // namespace semmap
