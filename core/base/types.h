// Small vocabulary types shared by every part of flipflow. nvcc-clean (std headers only).
#pragma once
#include <cstdint>
#include <string>

struct CUstream_st;  // = cudaStream_t, without pulling the CUDA runtime into every header

namespace ff {

enum class Precision : std::uint8_t { f32, f64 };
enum class Backend : std::uint8_t { cpu, cuda };
enum class DType : std::uint8_t { f32, f64, i32, u32, i64, u64, u8 };

std::size_t dtype_size(DType t);
const char* to_string(Precision p);
const char* to_string(Backend b);
const char* to_string(DType t);

template <class T> constexpr DType dtype_of();
template <> constexpr DType dtype_of<float>() { return DType::f32; }
template <> constexpr DType dtype_of<double>() { return DType::f64; }
template <> constexpr DType dtype_of<std::int32_t>() { return DType::i32; }
template <> constexpr DType dtype_of<std::uint32_t>() { return DType::u32; }
template <> constexpr DType dtype_of<std::int64_t>() { return DType::i64; }
template <> constexpr DType dtype_of<std::uint64_t>() { return DType::u64; }
template <> constexpr DType dtype_of<std::uint8_t>() { return DType::u8; }

inline DType real_dtype(Precision p) { return p == Precision::f32 ? DType::f32 : DType::f64; }

}  // namespace ff
