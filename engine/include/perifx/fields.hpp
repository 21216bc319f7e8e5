// perifx public API: a named, typed, read-only view of one array, so writers and host tools can find
// fields by name without knowing the component structs. The list of fields comes from the systems
// that produce them (systems/field_registry.hpp); `perifx info` and the docs print it.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace perifx {

enum class FieldType : std::uint8_t { f64, f32, u32, u16, u8 };

enum class FieldLocation : std::uint8_t { particle, bond };

struct FieldView {
  std::string name;           // e.g. "velocity"
  FieldType type = FieldType::f64;
  int components = 1;         // 1 scalar, 3 vector
  FieldLocation location = FieldLocation::particle;
  const void* data = nullptr; // count × components values of `type`, contiguous; valid until the
                              // world steps or is destroyed
  std::size_t count = 0;      // number of tuples
  std::string unit;           // SI unit, for documentation ("m/s")
  std::string doc;            // one line
};

inline std::size_t field_type_size(FieldType t) {
  switch (t) {
    case FieldType::f64: return 8;
    case FieldType::f32: return 4;
    case FieldType::u32: return 4;
    case FieldType::u16: return 2;
    case FieldType::u8: return 1;
  }
  return 0;
}

}  // namespace perifx
