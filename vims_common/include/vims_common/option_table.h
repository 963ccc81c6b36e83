#pragma once
/// @file option_table.h
/// @brief Options described once: one table per options struct drives reading, checking and printing.
///
/// An options struct keeps its fields, their defaults and the comment saying why each default
/// is what it is. Its table lists every field once: the YAML key, how to reach the member, and
/// the values it may take. The table is then the single source of
/// - the known keys (a misspelt key is a ConfigError naming it and listing the known ones),
/// - the parsing (a value of the wrong type is a ConfigError naming the key),
/// - the range checks, on a file's values and on options built in code (firstViolation),
/// - toYaml, whose text reads back to the same options (numbers in their shortest exact form).
/// Rules that relate two fields (a maximum above its minimum) are part of the table too, so a
/// nested section is checked as fully as the struct read on its own.
///
/// Typical use, in the struct's .cpp:
///   const OptionTable<SonarFilterOptions>& SonarFilterOptions::optionTable() {
///     static const auto table = OptionTable<SonarFilterOptions>()
///         .integer("window_size", &SonarFilterOptions::window_size, Bounds::closed(3, 200))
///         .number("gate_sigma", &SonarFilterOptions::gate_sigma, Bounds::closed(1.0, 20.0));
///     return table;
///   }

#include <functional>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "vims_common/config_reader.h"

namespace vims {

/// The values a numeric option may take; every bound excludes NaN and the infinities.
class Bounds {
 public:
  static Bounds any();                         ///< any finite value
  static Bounds positive();                    ///< > 0
  static Bounds nonNegative();                 ///< >= 0
  static Bounds closed(double lo, double hi);  ///< in [lo, hi]
  /// Empty when `value` is allowed, otherwise "must be ..., got <value>".
  std::string violation(double value) const;
  /// The allowed values as text for the parameters doc: "> 0", ">= 0", "[1, 10]", "any".
  std::string describe() const;

 private:
  Bounds(double lo, double hi, bool lo_open) : lo_(lo), hi_(hi), lo_open_(lo_open) {}
  double lo_;
  double hi_;
  bool lo_open_;
};

/// The shortest text that reads back as exactly `value` ("0.1", "2", "1e-05").
std::string formatOptionNumber(double value);
/// `text` as a double-quoted YAML scalar (backslashes and quotes escaped).
std::string quoteYaml(const std::string& text);
/// Prefixes every line of `block` with `prefix` (to nest a YAML block under a key).
std::string indentYaml(const std::string& block, const std::string& prefix);

/// One key of a table (sections expanded to dotted paths) and the values it accepts.
struct OptionRow {
  std::string key;
  std::string allowed;
};

/// A key path and what is wrong with its value.
struct OptionViolation {
  std::string key;
  std::string message;
};

/// A rule's verdict: the violation when `broken`, otherwise none.
inline std::optional<OptionViolation> violationIf(bool broken, const std::string& key, const std::string& message) {
  if (!broken) return std::nullopt;
  return OptionViolation{key, message};
}

/// Keeps a template parameter out of deduction (it is given or defaulted, not read off an argument).
template <typename T>
struct NonDeduced {
  using type = T;
};

template <typename Options>
class OptionTable {
 public:
  /// How a field is reached from the struct: a data member pointer or a lambda (for a member of
  /// a member, e.g. `[](Options& o) -> double& { return o.trajectory.rpe_delta_m; }`).
  template <typename T>
  using Access = std::function<T&(Options&)>;

  OptionTable& flag(std::string key, typename NonDeduced<Access<bool>>::type access) {
    return add(
        std::move(key),
        [access](const ConfigReader& r, const std::string& k, Options& o) { access(o) = r.get<bool>(k); },
        [](const Options&) { return std::string(); },
        [access](const Options& o) { return std::string(access(mut(o)) ? "true" : "false"); }, "true, false");
  }

  /// A whole number of type T (int by default; `integer<uint64_t>` for a seed).
  template <typename T = int>
  OptionTable& integer(std::string key, typename NonDeduced<Access<T>>::type access, Bounds bounds) {
    return add(
        std::move(key), [access](const ConfigReader& r, const std::string& k, Options& o) { access(o) = r.get<T>(k); },
        [access, bounds](const Options& o) { return bounds.violation(static_cast<double>(access(mut(o)))); },
        [access](const Options& o) { return std::to_string(access(mut(o))); }, "whole number " + bounds.describe());
  }

  OptionTable& number(std::string key, Access<double> access, Bounds bounds) {
    return scaledNumber(std::move(key), std::move(access), 1.0, bounds);
  }

  /// A number the code keeps in other units than the file: member = file value * `unit` (for
  /// example degrees in the file, radians in the code). Bounds and toYaml are in the file's unit.
  OptionTable& scaledNumber(std::string key, Access<double> access, double unit, Bounds bounds) {
    return add(
        std::move(key),
        [access, unit](const ConfigReader& r, const std::string& k, Options& o) {
          access(o) = r.get<double>(k) * unit;
        },
        [access, unit, bounds](const Options& o) { return bounds.violation(access(mut(o)) / unit); },
        [access, unit](const Options& o) {
          return formatOptionNumber(unit == 1.0 ? access(mut(o)) : roundToTwelveDigits(access(mut(o)) / unit));
        },
        bounds.describe());
  }

  OptionTable& text(std::string key, Access<std::string> access, bool may_be_empty) {
    return add(
        std::move(key),
        [access](const ConfigReader& r, const std::string& k, Options& o) { access(o) = r.get<std::string>(k); },
        [access, may_be_empty](const Options& o) {
          return !may_be_empty && access(mut(o)).empty() ? std::string("must not be empty") : std::string();
        },
        [access](const Options& o) { return quoteYaml(access(mut(o))); }, may_be_empty ? "text" : "non-empty text");
  }

  /// An enumeration written in the file as `name(value)` of one of `values`.
  template <typename E>
  OptionTable& choice(std::string key, typename NonDeduced<Access<E>>::type access, std::vector<E> values,
                      std::function<std::string(E)> name) {
    return add(
        std::move(key),
        [access, values, name](const ConfigReader& r, const std::string& k, Options& o) {
          const std::string text = r.get<std::string>(k);
          for (const E value : values) {
            if (name(value) == text) {
              access(o) = value;
              return;
            }
          }
          throw r.error(k, "must be one of " + nameList(values, name) + "; got '" + text + "'");
        },
        [](const Options&) { return std::string(); }, [access, name](const Options& o) { return name(access(mut(o))); },
        nameList(values, name));
  }

  /// A nested mapping read by its own table; an absent section keeps the member's defaults.
  template <typename Sub>
  OptionTable& section(std::string key, typename NonDeduced<Access<Sub>>::type access, const OptionTable<Sub>& table) {
    add(
        std::move(key),
        [access, table](const ConfigReader& r, const std::string& k, Options& o) {
          table.read(r.child(k), &access(o));
        },
        [access, table](const Options& o) -> std::string {
          const auto v = table.firstViolation(access(mut(o)));
          return v ? v->key + ": " + v->message : std::string();
        },
        [access, table](const Options& o) { return "\n" + indentYaml(table.toYaml(access(mut(o))), "  "); }, "");
    const std::string prefix = fields_.back().key + ".";
    fields_.back().rows = [table, prefix] {
      std::vector<OptionRow> rows = table.rows();
      for (OptionRow& row : rows) row.key = prefix + row.key;
      return rows;
    };
    return *this;
  }

  /// A field no other kind fits: `read` parses the present key (throwing reader.error on a bad
  /// value), `yaml` gives the text after "key: " (starting with a newline for a block).
  OptionTable& custom(std::string key, std::function<void(const ConfigReader&, const std::string&, Options&)> read,
                      std::function<std::string(const Options&)> yaml, const std::string& allowed) {
    return add(
        std::move(key), std::move(read), [](const Options&) { return std::string(); }, std::move(yaml), allowed);
  }

  /// A rule relating fields (a maximum above its minimum), checked after the fields on every
  /// read and by firstViolation: it returns the key to blame and why, or nothing.
  OptionTable& rule(std::function<std::optional<OptionViolation>(const Options&)> check) {
    rules_.push_back(std::move(check));
    return *this;
  }

  /// This table without `key` (a struct nested where one of its fields is set by its owner).
  OptionTable without(const std::string& key) const {
    OptionTable copy = *this;
    copy.fields_.clear();
    for (const Field& f : fields_)
      if (f.key != key) copy.fields_.push_back(f);
    return copy;
  }

  /// Reads the fields present in `reader` into `options` (absent ones keep their value) and
  /// checks every field. Throws ConfigError naming the key: unknown key, wrong type, bad value.
  void read(const ConfigReader& reader, Options* options) const {
    std::set<std::string> known;
    for (const Field& f : fields_) known.insert(f.key);
    reader.rejectUnknownKeys(known);
    for (const Field& f : fields_) {
      if (reader.has(f.key)) f.read(reader, f.key, *options);
      const std::string message = f.violation(*options);
      if (!message.empty()) throw reader.error(f.key, message);
    }
    for (const auto& check : rules_) {
      if (const auto v = check(*options)) throw reader.error(v->key, v->message);
    }
  }

  /// The first field whose value is not allowed (for options built in code), or none.
  std::optional<OptionViolation> firstViolation(const Options& options) const {
    for (const Field& f : fields_) {
      const std::string message = f.violation(options);
      if (!message.empty()) return OptionViolation{f.key, message};
    }
    for (const auto& check : rules_) {
      if (auto v = check(options)) return v;
    }
    return std::nullopt;
  }

  /// Every field as YAML in the table's order; reading it back gives the same options.
  std::string toYaml(const Options& options) const {
    std::string out;
    for (const Field& f : fields_) {
      const std::string value = f.yaml(options);
      out += f.key + ":" + (value.rfind('\n', 0) == 0 ? "" : " ") + value;
      if (out.back() != '\n') out += "\n";
    }
    return out;
  }

  /// Every key with the values it accepts, a section's keys as dotted paths below it.
  std::vector<OptionRow> rows() const {
    std::vector<OptionRow> out;
    for (const Field& f : fields_)
      for (const OptionRow& row : f.rows()) out.push_back(row);
    return out;
  }

 private:
  struct Field {
    std::string key;
    std::function<void(const ConfigReader&, const std::string&, Options&)> read;  ///< key present
    std::function<std::string(const Options&)> violation;                         ///< empty: fine
    std::function<std::string(const Options&)> yaml;                              ///< text after "key:"
    std::function<std::vector<OptionRow>()> rows;  ///< the key with its allowed values (a section: its keys)
  };

  OptionTable& add(std::string key, std::function<void(const ConfigReader&, const std::string&, Options&)> read,
                   std::function<std::string(const Options&)> violation,
                   std::function<std::string(const Options&)> yaml, const std::string& allowed) {
    std::function<std::vector<OptionRow>()> rows = [key, allowed] { return std::vector<OptionRow>{{key, allowed}}; };
    fields_.push_back(Field{std::move(key), std::move(read), std::move(violation), std::move(yaml), std::move(rows)});
    return *this;
  }

  template <typename E>
  static std::string nameList(const std::vector<E>& values, const std::function<std::string(E)>& name) {
    std::string list;
    for (const E value : values) list += (list.empty() ? "" : ", ") + name(value);
    return list;
  }

  /// The accessors take a mutable struct so that one lambda serves reading and printing; the
  /// printing and checking paths only read through it.
  static Options& mut(const Options& o) { return const_cast<Options&>(o); }

  /// A value converted back to the file's unit carries the conversion's rounding (2 deg comes
  /// back as 1.9999999999999998): twelve digits print what the user wrote.
  static double roundToTwelveDigits(double value) {
    std::ostringstream os;
    os.precision(12);
    os << value;
    return std::stod(os.str());
  }

  std::vector<Field> fields_;
  std::vector<std::function<std::optional<OptionViolation>(const Options&)>> rules_;
};

/// Options built in code (tests, tools) get the checks a file gets: throws std::invalid_argument
/// "<owner>: invalid <key>: <why>" for the first value the table rejects.
template <typename Options>
void throwIfInvalid(const OptionTable<Options>& table, const Options& options, const std::string& owner) {
  if (const auto v = table.firstViolation(options)) {
    throw std::invalid_argument(owner + ": invalid " + v->key + ": " + v->message);
  }
}

/// Options with their defaults overwritten by `reader` through Options::optionTable().
template <typename Options>
Options readOptions(const ConfigReader& reader) {
  Options options;
  Options::optionTable().read(reader, &options);
  return options;
}

}  // namespace vims
