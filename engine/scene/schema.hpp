// Internal to engine/scene: the declarative scene spec (one table: every key's type, default,
// range and doc) and the validator that walks JSON against it. The converter in load.cpp and the
// markdown reference are both driven by this table, so the docs and the checks cannot disagree.
#pragma once
#include <cstddef>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace perifx::scene::detail {

// Ordered, so materials keep their file order (which fixes their indices in Scene::materials).
using Json = nlohmann::ordered_json;

enum class Type {
  number,            // finite double (or +∞ via "inf" when allowed)
  integer,           // int, integral JSON number
  boolean,
  string,
  enumeration,       // one string of `choices`
  vec3,              // [x, y, z]
  vec3_list,         // [[x, y, z], ...] (min_items: at least that many points)
  mat3,              // [[..],[..],[..]], rows
  object,            // fixed keys (`keys`)
  map,               // {"<name>": object with `keys`, ...}
  array,             // [object with `keys`, ...]
  string_list,       // [string, ...], from `choices` when given
  number_or_object,  // a number, or an object with `keys` (e.g. horizon: 1.45 or {"length": 0.01})
};

struct Key {
  std::string name;
  Type type = Type::number;
  std::string doc;
  Json default_value;           // null: no default (optional unless `required`)
  std::string default_doc;      // shown instead, for defaults computed by the converter
  bool required = false;
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false, hi_open = false;
  bool allow_inf = false;       // number: "inf"/"infinity" means +∞ (JSON has no Infinity)
  bool allow_auto = false;      // number: the string "auto" is kept for the converter to resolve
  bool nonzero = false;         // vec3: a direction, must not be [0, 0, 0]
  bool allow_empty = false;     // string
  std::size_t min_items = 0;    // map, array, string_list
  std::vector<std::string> choices;   // enumeration, string_list
  std::vector<std::string> only_for;  // key used only when the enclosing object's "type" is one of these
  // The object this key holds (object), or each entry / item (map, array, number_or_object):
  std::string label;            // its name in messages: "geometry", "material", ...
  std::vector<Key> keys;
  // Mutually exclusive key groups: at most one group may appear, and a group that appears must be
  // complete (members with a default are filled). `need_group`: one group is mandatory.
  std::vector<std::vector<std::string>> groups;
  bool need_group = false;

  // Builder setters, so the spec table reads as one declaration per key.
  Key& def(Json v) { default_value = std::move(v); return *this; }
  Key& def_text(std::string s) { default_doc = std::move(s); return *this; }
  Key& req() { required = true; return *this; }
  Key& gt(double v) { lo = v; lo_open = true; return *this; }
  Key& ge(double v) { lo = v; lo_open = false; return *this; }
  Key& lt(double v) { hi = v; hi_open = true; return *this; }
  Key& le(double v) { hi = v; hi_open = false; return *this; }
  Key& or_inf() { allow_inf = true; return *this; }
  Key& or_auto() { allow_auto = true; return *this; }
  Key& not_zero() { nonzero = true; return *this; }
  Key& empty_ok() { allow_empty = true; return *this; }
  Key& at_least(std::size_t n) { min_items = n; return *this; }
  Key& only(std::vector<std::string> types) { only_for = std::move(types); return *this; }
  Key& one_of(std::vector<std::vector<std::string>> g, bool needed) {
    groups = std::move(g);
    need_group = needed;
    return *this;
  }
};

// The root of the spec: an object whose `keys` are the top-level scene keys.
const Key& scene_spec();
// A complete scene in the documented format (shown in the reference; a test loads it).
const std::string& example_scene();

// Checks `root` against the spec, throwing SceneError(file, pointer, ...) at the first problem.
// On success every default is filled in and "inf" strings are replaced by +∞, so the converter
// can read every key with a default without checking for it.
void validate(Json& root, const std::string& file);

// Message helpers shared with the converter.
std::string show(const Json& value);                 // compact JSON text for "(got ...)"
std::string cut(const std::string& text);            // echoed text: at most 80 bytes + "…", one line
std::string child_pointer(const std::string& pointer, const std::string& key);  // RFC 6901 escaping
// The candidate closest to `word` by edit distance, or "" when none is plausibly a typo of it.
std::string closest(const std::string& word, const std::vector<std::string>& candidates);
std::string join(const std::vector<std::string>& items, const std::string& separator = ", ");

}  // namespace perifx::scene::detail
