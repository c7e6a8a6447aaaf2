/* fuzz_cli.c - option parsing (cli_args.h) on arbitrary argument vectors: the input split at
 * NUL and newline bytes into at most 24 arguments, parsed against a table holding every option
 * kind, then the value parsers of --light-rotation, --camera, --layout and output paths on the
 * first arguments. Stderr is captured: a usage error (2) is exactly one line "prt fuzz: ...",
 * a success prints nothing, and every parsed value is inside its option's range. */
#include "fuzz.h"
#include "cli_args.h"
#include "scene.h"

#define MAX_ARGS 24

/* Stderr into memory around a call: the library prints with stdio on stderr, so the FILE is
 * swapped for a memory stream (no dup2, ftruncate or write per call: those system calls were
 * 40% of an input's time). Harness state, per process. */
static char cap_buf[1 << 16];
static FILE *cap_file, *saved_err;
static void cap_begin(void) {
    if (!cap_file) cap_file = fmemopen(cap_buf, sizeof cap_buf, "w");
    if (!cap_file) abort();
    rewind(cap_file);
    fflush(stderr);
    saved_err = stderr;
    stderr = cap_file;
}
/* Ends the capture; returns what was printed (truncated at the buffer's size). */
static const char *cap_end(size_t *len) {
    fflush(cap_file);
    stderr = saved_err;
    long n = ftell(cap_file);
    *len = n > 0 ? ((size_t)n < sizeof cap_buf ? (size_t)n : sizeof cap_buf - 1) : 0;
    cap_buf[*len] = 0;
    return cap_buf;
}

/* What a failing call printed: one line "prt fuzz: ..." ending in a newline. */
static void check_one_line(const char *out, size_t len, const char *what) {
    FUZZ_REQUIRE(len > 11 && !strncmp(out, "prt fuzz: ", 10), "%s: error not 'prt fuzz: ...': '%s'", what, out);
    FUZZ_REQUIRE(out[len - 1] == '\n' && memchr(out, '\n', len) == out + len - 1, "%s: error spans lines: '%s'", what, out);
}

static void parse_table(int argc, char **argv) {
    const char *s = NULL, *pos[2] = { 0 };
    int i = -7, oi = -7, oiset = 0, setv = 0, wh[2] = { -7, -7 }, npos = 0;
    float f = -7;
    bool flag = false;
    const cli_option opts[] = {
        CLI_S("-o", &s), CLI_I("--int", &i, -5, 100), CLI_F("--float", &f, 0, 1), CLI_WH("--size", wh),
        CLI_B("--flag", &flag), CLI_SETV("--set", &setv, 3), CLI_OI("--floor", &oi, 4, 4000000, &oiset, 1), CLI_END,
    };
    cap_begin();
    int rc = cli_parse("fuzz", argc, argv, opts, pos, 2, &npos);
    size_t len;
    const char *out = cap_end(&len);
    FUZZ_REQUIRE(rc == 0 || rc == 1 || rc == 2, "cli_parse returned %d", rc);
    if (rc == 2) { check_one_line(out, len, "cli_parse"); return; }
    FUZZ_REQUIRE(len == 0, "cli_parse printed '%s' and returned %d", out, rc);
    if (rc == 1) return;
    FUZZ_REQUIRE(npos >= 0 && npos <= 2, "%d positional arguments", npos);
    FUZZ_REQUIRE(i == -7 || (i >= -5 && i <= 100), "--int %d out of range", i);
    FUZZ_REQUIRE(f == -7 || (f >= 0 && f <= 1), "--float %g out of range", (double)f);
    FUZZ_REQUIRE(oi == -7 || (oi >= 4 && oi <= 4000000), "--floor %d out of range", oi);
    FUZZ_REQUIRE(wh[0] == -7 || (wh[0] >= 1 && wh[0] <= 16384 && wh[1] >= 1 && wh[1] <= 16384), "--size %dx%d", wh[0], wh[1]);
}

/* The value parsers that take a free string: rotation, layout, camera, image path. */
static void parse_values(const char *a) {
    static prt_scene scene;   /* a small sphere for cli_camera, built once per process */
    if (!scene.mesh.nverts) {
        prt_mesh m;
        prt_error e;
        const float c[3] = { 0, 0, 0 };
        if (mesh_make_sphere(&m, c, 1, 8, 16, &e) || scene_from_mesh(&m, NULL, &scene, &e)) abort();
    }
    float R[9];
    size_t len;
    cap_begin();
    int rc = cli_rotation("fuzz", a, R);
    const char *out = cap_end(&len);
    if (rc) check_one_line(out, len, "cli_rotation");
    else for (int k = 0; k < 9; k++) FUZZ_REQUIRE(isfinite(R[k]) && fabsf(R[k]) <= 1.0001f, "rotation entry %g", (double)R[k]);
    probe_layout l;
    if (probe_parse_layout(a, &l) == 0) FUZZ_REQUIRE(l >= PROBE_AUTO && l <= PROBE_CROSS, "layout %d", (int)l);
    prt_camera cam;
    cap_begin();
    rc = cli_camera("fuzz", &scene, 1.5f, a, NULL, &cam);
    out = cap_end(&len);
    if (rc) check_one_line(out, len, "cli_camera");
    cap_begin();
    rc = cli_check_output("fuzz", a, CLI_OUT_IMAGE);
    out = cap_end(&len);
    if (rc) check_one_line(out, len, "cli_check_output");
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    char *text = fuzz_cstr(data, size);
    char *argv[MAX_ARGS + 1] = { "prt" };
    int argc = 1;
    char *p = text, *end = text + size;
    while (p <= end && argc < MAX_ARGS) {
        char *q = p;
        while (q < end && *q && *q != '\n') q++;
        *q = 0;
        argv[argc++] = p;
        p = q + 1;
    }
    argv[argc] = NULL;
    parse_table(argc, argv);
    parse_values(argv[1]);
    if (argc > 2) parse_values(argv[2]);
    free(text);
    return 0;
}
