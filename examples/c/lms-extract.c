/*
 * lms-extract: the lines of every scan of a CARMEN log, through the C API
 * of lms-features (capi/include/lms_features.h), as JSON Lines:
 *
 *   {"frame": k, "lines": [{"alpha": a, "r": r, "first": f, "last": l}, ...]}
 *
 * Floats are printed with %.9g (they read back to the same float). The
 * result equals the lines of `host-bridge extract LOG`, because the log is
 * read the way host-bridge reads it:
 *
 *   1. the unit: mm if at least a quarter of the range values show three or
 *      more decimals, cm otherwise (as lms_core::carmen::UnitVote);
 *   2. every range as LMS units, round(metres x units per metre), so that
 *      the sensor's error codes keep their meaning; a value with more
 *      decimals than its unit is refused (no shared log has one);
 *   3. sigma and max_range from a survey of the whole log
 *      (lms_survey_add_units / lms_survey_params, as host-bridge's
 *      defaults per data);
 *   4. each scan through lms_extract_units.
 *
 * Usage: lms-extract LOG            (LOG plain text, or gzip through `gzip -dc`)
 *        lms-extract --emit-c N LOG (a C source with the first N scans as
 *                                    LMS units and the parameters, for the
 *                                    MCU example)
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lms_features.h"

/* One scan as LMS units. */
typedef struct {
    LmsVariant variant;
    size_t n;
    uint16_t raw[LMS_MAX_BEAMS];
} Scan;

static void die(const char *what) {
    fprintf(stderr, "lms-extract: %s\n", what);
    exit(1);
}

static void die_code(const char *call, int code) {
    fprintf(stderr, "lms-extract: %s: %s (%d)\n", call, lms_error_message(code), code);
    exit(1);
}

/* The whole text of `path`, gunzipped by `gzip -dc` if it starts with the
 * gzip magic 1f 8b. */
static char *read_text(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "lms-extract: cannot open %s: %s\n", path, strerror(errno));
        exit(1);
    }
    unsigned char magic[2] = {0, 0};
    size_t got = fread(magic, 1, 2, f);
    fclose(f);
    int gzip = got == 2 && magic[0] == 0x1f && magic[1] == 0x8b;
    if (gzip) {
        /* The path goes to the shell in single quotes. */
        size_t plen = strlen(path);
        char *cmd = malloc(plen * 4 + 32);
        if (!cmd) die("out of memory");
        char *c = cmd + sprintf(cmd, "gzip -dc -- '");
        for (const char *p = path; *p; p++) {
            if (*p == '\'') { memcpy(c, "'\\''", 4); c += 4; } else { *c++ = *p; }
        }
        strcpy(c, "'");
        f = popen(cmd, "r");
        free(cmd);
    } else {
        f = fopen(path, "rb");
    }
    if (!f) die("cannot read the log");
    size_t cap = 1 << 20, n = 0;
    char *buf = malloc(cap + 1);
    if (!buf) die("out of memory");
    for (;;) {
        if (n == cap) {
            cap *= 2;
            buf = realloc(buf, cap + 1);
            if (!buf) die("out of memory");
        }
        size_t k = fread(buf + n, 1, cap - n, f);
        if (k == 0) break;
        n += k;
    }
    int bad = gzip ? pclose(f) != 0 : (ferror(f) || fclose(f) != 0);
    if (bad) die("cannot read or decompress the log");
    buf[n] = '\0';
    *len = n;
    return buf;
}

/* Digits after the decimal point, before anything else. */
static int decimals(const char *t, size_t len) {
    const char *dot = memchr(t, '.', len);
    if (!dot) return 0;
    int d = 0;
    for (const char *p = dot + 1; p < t + len && *p >= '0' && *p <= '9'; p++) d++;
    return d;
}

/* The next whitespace-separated word of [*p, end): its start and length. */
static int word(const char **p, const char *end, const char **w, size_t *len) {
    const char *s = *p;
    while (s < end && (*s == ' ' || *s == '\t' || *s == '\r' || *s == '\v' || *s == '\f')) s++;
    const char *e = s;
    while (e < end && !(*e == ' ' || *e == '\t' || *e == '\r' || *e == '\v' || *e == '\f')) e++;
    *p = e;
    *w = s;
    *len = (size_t)(e - s);
    return e > s;
}

/* A word as a NUL-terminated copy (range and field texts are short). */
static void copy_word(char *dst, size_t cap, const char *w, size_t len) {
    if (len >= cap) len = cap - 1;
    memcpy(dst, w, len);
    dst[len] = '\0';
}

/* Units of a range unit per metre, its all-ones value and first error code. */
static void unit_numbers(LmsUnit unit, double *per_metre, long *all_ones) {
    *per_metre = unit == LMS_UNIT_MM ? 1000.0 : 100.0;
    *all_ones = unit == LMS_UNIT_MM ? 32767 : 8191;
}

/* Parse one FLASER line [line, end). With `scan` NULL only count the range
 * values and those with three or more decimals; else fill `scan` in
 * `unit`. Returns 0 on success, else a message. */
static const char *parse_flaser(const char *line, const char *end, LmsUnit unit, Scan *scan,
                                unsigned long long *ranges, unsigned long long *three) {
    const char *p = line, *w;
    size_t len;
    char text[64];
    word(&p, end, &w, &len); /* FLASER */
    if (!word(&p, end, &w, &len)) return "no beam count after FLASER";
    copy_word(text, sizeof text, w, len);
    char *stop;
    unsigned long n = strtoul(text, &stop, 10);
    if (*stop || text[0] == '-' || text[0] == '+') return "malformed beam count";
    LmsVariant variant;
    if (lms_variant_for_beams(n, &variant) != LMS_OK) return "unsupported beam count";
    /* Count the fields after n: n ranges + 9. */
    size_t after = 0;
    for (const char *q = p; word(&q, end, &w, &len);) after++;
    if (after != n + 9) return "wrong number of fields after the beam count";
    double per_metre;
    long all_ones;
    unit_numbers(unit, &per_metre, &all_ones);
    for (unsigned long j = 0; j < n; j++) {
        word(&p, end, &w, &len);
        copy_word(text, sizeof text, w, len);
        double m = strtod(text, &stop);
        if (*stop || !isfinite(m)) return "malformed range";
        if (m < 0) return "negative range";
        if (!scan) {
            *ranges += 1;
            *three += decimals(w, len) >= 3;
            continue;
        }
        long code = (long)round(m * per_metre);
        if (code > all_ones) return "range above the largest LMS value of the unit";
        if (code < all_ones - 8 && (float)code / (float)per_metre != strtof(text, NULL))
            return "range with more decimals than the unit (lms-extract reads LMS units)";
        scan->raw[j] = (uint16_t)code;
    }
    /* The pose and time fields: numbers but the host name (8th). */
    for (int k = 0; k < 9; k++) {
        word(&p, end, &w, &len);
        if (k == 7) continue;
        copy_word(text, sizeof text, w, len);
        strtod(text, &stop);
        if (*stop || len == 0) return "malformed pose or time field";
    }
    if (scan) {
        scan->variant = variant;
        scan->n = n;
    }
    return NULL;
}

/* `true` if the first word of [line, end) is FLASER. */
static int is_flaser(const char *line, const char *end) {
    const char *p = line, *w;
    size_t len;
    return word(&p, end, &w, &len) && len == 6 && memcmp(w, "FLASER", 6) == 0;
}

/* Every FLASER scan of `text`: the unit decision, then the scans in it.
 * A last line without newline that does not parse ends the log (cut). */
static Scan *read_scans(const char *path, char *text, size_t len, LmsUnit *unit_out,
                        size_t *count) {
    const char *end = text + len;
    unsigned long long ranges = 0, three = 0;
    size_t lines = 0;
    for (int pass = 0; pass < 2; pass++) {
        LmsUnit unit = LMS_UNIT_CM;
        if (pass == 1) {
            if (three > 0 && three * 4 >= ranges) unit = LMS_UNIT_MM;
            else if (three > 0)
                fprintf(stderr, "lms-extract: %s: ambiguous unit, read as cm\n", path);
            *unit_out = unit;
        }
        Scan *scans = pass == 1 ? malloc((lines ? lines : 1) * sizeof(Scan)) : NULL;
        if (pass == 1 && !scans) die("out of memory");
        size_t k = 0, number = 0;
        for (const char *line = text; line < end;) {
            const char *nl = memchr(line, '\n', (size_t)(end - line));
            const char *stop = nl ? nl : end;
            number++;
            if (is_flaser(line, stop)) {
                const char *err = parse_flaser(line, stop, unit, pass ? &scans[k] : NULL,
                                               &ranges, &three);
                if (err && !nl) {
                    fprintf(stderr, "lms-extract: %s: line %zu: cut (%s)\n", path, number, err);
                    break;
                }
                if (err) {
                    fprintf(stderr, "lms-extract: %s: line %zu: %s\n", path, number, err);
                    exit(1);
                }
                k++;
            }
            line = nl ? nl + 1 : end;
        }
        if (pass == 0) lines = k;
        else {
            *count = k;
            return scans;
        }
    }
    return NULL;
}

/* The parameters of the whole log: defaults with its sigma and max_range. */
static LmsParams params_of(const Scan *scans, size_t count, LmsUnit unit) {
    static LmsSurvey survey;
    int code = lms_survey_init(&survey, unit);
    if (code != LMS_OK) die_code("lms_survey_init", code);
    for (size_t k = 0; k < count; k++) {
        code = lms_survey_add_units(&survey, scans[k].variant, scans[k].raw, scans[k].n);
        if (code != LMS_OK) die_code("lms_survey_add_units", code);
    }
    LmsParams params;
    code = lms_survey_params(&survey, &params);
    if (code != LMS_OK) die_code("lms_survey_params", code);
    return params;
}

static void emit_c(const Scan *scans, size_t count, size_t frames, LmsUnit unit,
                   const LmsParams *p) {
    if (frames > count) frames = count;
    size_t n = frames ? scans[0].n : 0;
    for (size_t k = 0; k < frames; k++)
        if (scans[k].n != n || scans[k].variant != scans[0].variant)
            die("--emit-c: the scans differ in beam count");
    printf("/* Generated by lms-extract --emit-c from a CARMEN log: LMS units. */\n");
    printf("#include \"frames.h\"\n");
    printf("const float frames_sigma = %af;\n", (double)p->sigma);
    printf("const float frames_max_range = %af;\n", (double)p->max_range);
    printf("const LmsUnit frames_unit = %u;\n", (unsigned)unit);
    printf("const LmsVariant frames_variant = %u;\n", (unsigned)(frames ? scans[0].variant : 0));
    printf("const size_t frames_count = %zu;\n", frames);
    printf("const size_t frames_beams = %zu;\n", n);
    printf("const uint16_t frames_raw[] = {\n");
    for (size_t k = 0; k < frames; k++) {
        for (size_t j = 0; j < n; j++) printf("%u,", scans[k].raw[j]);
        printf("\n");
    }
    printf("0};\n");
}

int main(int argc, char **argv) {
    long emit = -1;
    const char *path = NULL;
    if (argc == 4 && strcmp(argv[1], "--emit-c") == 0) {
        char *stop;
        emit = strtol(argv[2], &stop, 10);
        if (*stop || emit < 0) die("--emit-c N: N must be a count");
        path = argv[3];
    } else if (argc == 2 && argv[1][0] != '-') {
        path = argv[1];
    } else {
        fprintf(stderr, "usage: lms-extract LOG | lms-extract --emit-c N LOG  (library %s)\n",
                lms_version());
        return 2;
    }
    size_t len, count;
    char *text = read_text(path, &len);
    LmsUnit unit = LMS_UNIT_CM;
    Scan *scans = read_scans(path, text, len, &unit, &count);
    free(text);
    if (count == 0) die("the log holds no FLASER scans");
    LmsParams params = params_of(scans, count, unit);
    if (emit >= 0) {
        emit_c(scans, count, (size_t)emit, unit, &params);
        free(scans);
        return 0;
    }
    static LmsFeatures out; /* ~15 KiB: not on the stack */
    for (size_t k = 0; k < count; k++) {
        int code = lms_extract_units(&params, scans[k].variant, unit, scans[k].raw,
                                     scans[k].n, &out);
        if (code != LMS_OK) die_code("lms_extract_units", code);
        printf("{\"frame\": %zu, \"lines\": [", k);
        for (uint32_t i = 0; i < out.n_lines; i++) {
            const LmsLine *l = &out.lines[i];
            printf("%s{\"alpha\": %.9g, \"r\": %.9g, \"first\": %u, \"last\": %u}", i ? ", " : "",
                   (double)l->alpha, (double)l->r, (unsigned)l->first, (unsigned)l->last);
        }
        printf("]}\n");
    }
    free(scans);
    return fflush(stdout) == 0 ? 0 : 1;
}
