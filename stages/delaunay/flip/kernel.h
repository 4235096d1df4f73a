// delaunay.flip per-element math: the repair round is decide + apply (common/flip.h) followed
// by the detection pass of delaunay.detect_inversion (MarkInversions, without the r⁰·r¹ test),
// which re-marks whatever inverted triangles remain. Nothing new is needed here.
#pragma once
#include "stages/delaunay/common/flip.h"
#include "stages/delaunay/detect_inversion/kernel.h"
