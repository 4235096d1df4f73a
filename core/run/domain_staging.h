// Domain's private state on CUDA (core/run/domain.h), shared by domain.cpp (refresh, the
// migration test, gather) and domain_migration.cpp (migrations).
#pragma once
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/run/domain.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include "core/backend/cuda/device_buffer.h"
#include "core/run/cuda/ghost_traffic.h"
#endif

namespace ff {

struct Domain::Staging {
#ifdef FLIPFLOW_HAVE_CUDA
  std::vector<std::unique_ptr<DeviceBuffer>> buffers;  // one per transfer slot, grown as needed
  std::unique_ptr<GhostTraffic> traffic;               // the refresh and the migration test
  // Per particle field: the device storage a migration on the device replaced, reused by the
  // next one (no allocation and free of every field at every migration).
  std::map<std::string, std::unique_ptr<DeviceBuffer>> spare;
#endif
};

}  // namespace ff
