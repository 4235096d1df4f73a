#include "stages/observe/h5md/frame.h"

namespace ff::observe {

void write_frame(H5mdWriter& w, Frame& f) {
  f.ready.wait();
  std::uint64_t bytes = 16 * f.observables.size();
  if (f.with_fields)
    for (const FieldFrame& field : f.fields) bytes += field.bytes.size();
  w.check_space(bytes);
  if (f.with_fields)
    for (const FieldFrame& field : f.fields) {
      if (field.connectivity)
        w.append_connectivity(field.name, f.step, f.time, reinterpret_cast<const std::int32_t*>(field.bytes.data()),
                              field.count);
      else
        w.append_particle_element(field.name, f.step, f.time, field.bytes.data());
    }
  for (const ObservableRow& o : f.observables) w.append_observable(o.name, o.step, o.time, o.value);
  w.flush();
}

}  // namespace ff::observe
