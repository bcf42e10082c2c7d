/* The scans embedded in the MCU example: build/frames.c, generated at build
 * time by `lms-extract --emit-c N LOG` (LMS units, and sigma / max_range of
 * the whole log's survey, as host-bridge extract uses them). */
#ifndef FRAMES_H
#define FRAMES_H
#include <stddef.h>
#include <stdint.h>
#include "lms_features.h"

extern const float frames_sigma;
extern const float frames_max_range;
extern const LmsUnit frames_unit;
extern const LmsVariant frames_variant;
extern const size_t frames_count;
extern const size_t frames_beams;
/* frames_count scans of frames_beams values each, scan after scan. */
extern const uint16_t frames_raw[];
#endif
