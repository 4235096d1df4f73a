#include "core/base/types.h"

namespace ff {

std::size_t dtype_size(DType t) {
  switch (t) {
    case DType::f32: case DType::i32: case DType::u32: return 4;
    case DType::f64: case DType::i64: case DType::u64: return 8;
    case DType::u8: return 1;
  }
  return 0;
}

const char* to_string(Precision p) { return p == Precision::f32 ? "float" : "double"; }
const char* to_string(Backend b) { return b == Backend::cpu ? "cpu" : "cuda"; }
const char* to_string(DType t) {
  switch (t) {
    case DType::f32: return "f32";
    case DType::f64: return "f64";
    case DType::i32: return "i32";
    case DType::u32: return "u32";
    case DType::i64: return "i64";
    case DType::u64: return "u64";
    case DType::u8: return "u8";
  }
  return "?";
}

}  // namespace ff
