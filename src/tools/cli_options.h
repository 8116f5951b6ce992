// Command-line parsing of the offline tools on CLI11 (libcli11-dev, header-only): CLI11 matches the
// options and collects their values; each tool keeps its own usage text and messages.
//
// Each value is checked by its option's callback as soon as CLI11 reads it, so an error is the
// first one on the command line, as "--help" is (it stops parsing where it stands, as before).
// Numbers are parsed here, strictly (the whole text a base-10 number, finite, in range), not by
// CLI11's conversion: that reads integers in base 0 ("010" is 8, "0x10" is 16), accepts "inf" and
// "nan", and goes through long double for floating point.
#pragma once

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <initializer_list>
#include <iostream>
#include <string>
#include <vector>

namespace mvod {
namespace cli {

constexpr int kExitOk = 0;
constexpr int kExitUsage = 2;  // bad arguments

inline bool parseLong(const std::string& text, long min_value, long max_value, long* value) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno != 0 || v < min_value || v > max_value) return false;
  *value = v;
  return true;
}

inline bool parseDouble(const std::string& text, double* value) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

// An app without CLI11's generated help (the tool prints its own usage text); a repeated option
// keeps its last value, a flag may be repeated. -h / --help: with `help` null it stops parsing
// where it stands (an unknown argument before it is still the error), else it sets *help and the
// tool shows its usage only when the whole command line parses (make_synthetic_dataset's rule).
inline void setUp(CLI::App* app, bool* help = nullptr) {
  app->set_help_flag();
  app->option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  app->add_flag_callback("-h,--help",
                         [app, help]() {
                           if (help != nullptr) {
                             *help = true;
                             return;
                           }
                           if (!app->remaining().empty()) throw CLI::ExtrasError(app->remaining());
                           throw CLI::CallForHelp();
                         })
      ->trigger_on_parse();
}

// An option with a value, handed to `accept` when it is read: `accept` returns "" or the message of
// the usage error.
inline CLI::Option* addValue(CLI::App* app, const std::string& name,
                             std::function<std::string(const std::string&)> accept) {
  return app
      ->add_option_function<std::string>(name,
                                         [accept](const std::string& text) {
                                           const std::string error = accept(text);
                                           if (!error.empty()) throw CLI::ValidationError(error);
                                         })
      ->trigger_on_parse();
}

// Text; an empty value is the error `if_empty` unless that is "".
inline CLI::Option* addText(CLI::App* app, const std::string& name, std::string* value,
                            const std::string& if_empty = "") {
  return addValue(app, name, [value, if_empty](const std::string& text) {
    if (text.empty() && !if_empty.empty()) return if_empty;
    *value = text;
    return std::string();
  });
}

// One of `choices`, else the error `message`.
inline CLI::Option* addChoice(CLI::App* app, const std::string& name,
                              std::initializer_list<const char*> choices, std::string* value,
                              const std::string& message) {
  std::vector<std::string> allowed(choices.begin(), choices.end());
  return addValue(app, name, [allowed, value, message](const std::string& text) {
    for (const std::string& choice : allowed) {
      if (text == choice) {
        *value = text;
        return std::string();
      }
    }
    return message;
  });
}

// A base-10 integer in [min_value, max_value], else the error `message`.
template <typename Integer>
CLI::Option* addInteger(CLI::App* app, const std::string& name, long min_value, long max_value,
                        Integer* value, const std::string& message) {
  return addValue(app, name, [=](const std::string& text) {
    long parsed = 0;
    if (!parseLong(text, min_value, max_value, &parsed)) return message;
    *value = static_cast<Integer>(parsed);
    return std::string();
  });
}

// A finite number for which `valid` holds, else the error `message`.
inline CLI::Option* addNumber(CLI::App* app, const std::string& name, double* value,
                              std::function<bool(double)> valid, const std::string& message) {
  return addValue(app, name, [=](const std::string& text) {
    double parsed = 0.0;
    if (!parseDouble(text, &parsed) || !valid(parsed)) return message;
    *value = parsed;
    return std::string();
  });
}

inline CLI::Option* addFlag(CLI::App* app, const std::string& name, bool* value) {
  return app->add_flag_callback(name, [value]() { *value = true; });
}

// Parses the command line: -1 when it is fine; kExitOk after printing `usage` to stdout for
// --help; kExitUsage after printing "<tool>: <message>" + separator + usage to stderr. `help`: the
// flag given to setUp, if any.
inline int parse(CLI::App* app, int argc, char** argv, const std::string& tool, const char* usage,
                 const char* separator = "\n\n", const bool* help = nullptr) {
  try {
    app->parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    std::cout << usage;
    return kExitOk;
  } catch (const CLI::ParseError& error) {
    std::cerr << tool << ": " << error.what() << separator << usage;
    return kExitUsage;
  }
  if (help != nullptr && *help) {
    std::cout << usage;
    return kExitOk;
  }
  return -1;
}

// A usage error found after parsing (a missing or inconsistent option).
inline int usageError(const std::string& tool, const std::string& message, const char* usage,
                      const char* separator = "\n\n") {
  std::cerr << tool << ": " << message << separator << usage;
  return kExitUsage;
}

}  // namespace cli
}  // namespace mvod
