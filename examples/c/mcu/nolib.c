/* Stand-ins for the two library functions the MCU example calls: linked
 * instead of liblms_capi.a to measure the flash the library adds (make
 * size-mcu). They touch the input, so that the data stays in the image. */
#include "lms_features.h"

LmsParams lms_params_default(void) {
    LmsParams p = {0};
    p.iterations = 30;
    return p;
}

int lms_extract_units(const LmsParams *params, LmsVariant variant, LmsUnit unit,
                      const uint16_t *raw, size_t n, LmsFeatures *out) {
    (void)params;
    (void)variant;
    (void)unit;
    out->n_lines = n > 0 ? (uint32_t)(raw[0] & 1) : 0;
    out->lines[0].first = n > 1 ? raw[1] : 0;
    return 0;
}
