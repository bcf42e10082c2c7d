/*
 * The lms-features core called from a C main on the STM32F405 (QEMU
 * netduinoplus2): the embedded scans (frames.h) through lms_extract_units,
 * one JSON line per scan through ARM semihosting, then a semihosting exit
 * (status 0 if every call succeeded).
 */
#include <stdio.h>
#include <string.h>

#include "frames.h"
#include "lms_features.h"
#include "semihosting.h"

/* ~15 KiB with the pipeline's working memory: static, not on the stack. */
static LmsFeatures out;
static char line[160];

int main(void) {
    LmsParams params = lms_params_default();
    params.sigma = frames_sigma;
    params.max_range = frames_max_range;
    int status = 0;
    for (size_t k = 0; k < frames_count; k++) {
        int code = lms_extract_units(&params, frames_variant, frames_unit,
                                     &frames_raw[k * frames_beams], frames_beams, &out);
        if (code != LMS_OK) {
            snprintf(line, sizeof line, "frame %u: error %d\n", (unsigned)k, code);
            semihost_write0(line);
            status = 1;
            break;
        }
        snprintf(line, sizeof line, "{\"frame\": %u, \"lines\": [", (unsigned)k);
        semihost_write0(line);
        for (uint32_t i = 0; i < out.n_lines && i < LMS_MAX_LINES; i++) {
            const LmsLine *l = &out.lines[i];
            snprintf(line, sizeof line, "%s{\"alpha\": %.9g, \"r\": %.9g, \"first\": %u, \"last\": %u}",
                     i ? ", " : "", (double)l->alpha, (double)l->r, (unsigned)l->first,
                     (unsigned)l->last);
            semihost_write0(line);
        }
        semihost_write0("]}\n");
    }
    semihost_exit(status);
    return status;
}
