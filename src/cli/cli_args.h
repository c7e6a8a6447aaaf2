/* cli_args.h - small helpers shared by the subcommands' argument parsing. */
#ifndef PRT_CLI_ARGS_H
#define PRT_CLI_ARGS_H
#include <stdbool.h>

/* If argv[*i] equals name, stores the next argument in *val, advances *i and returns 1;
 * returns -1 (after printing "prt CMD: NAME needs a value") when the value is missing; 0 otherwise. */
int cli_opt(const char *cmd, int argc, char **argv, int *i, const char *name, const char **val);
/* Parses an int / float fully; returns false on junk, prints "prt CMD: bad value for NAME: VAL". */
bool cli_int(const char *cmd, const char *name, const char *s, int lo, int hi, int *out);
bool cli_float(const char *cmd, const char *name, const char *s, float lo, float hi, float *out);
/* Parses "WxH". */
bool cli_size(const char *cmd, const char *s, int *w, int *h);
/* Table-driven options: each subcommand lists its options once; cli_parse does the
 * matching, value parsing, range checks and usage errors for all of them. */
typedef enum cli_kind {
    CLI_STR,      /* const char **out */
    CLI_INT,      /* int *out, in [lo, hi] */
    CLI_FLOAT,    /* float *out, in [lo, hi] */
    CLI_SIZE,     /* int out[2], "WxH" */
    CLI_FLAG,     /* bool *out = true (no value) */
    CLI_SET,      /* no value: only *set = setval */
    CLI_OPT_INT,  /* int *out, value optional (taken when the next argument starts with a digit) */
} cli_kind;

typedef struct cli_option {
    const char *name;   /* "--probe"; the table ends with a zero entry */
    cli_kind kind;
    void *out;
    double lo, hi;      /* CLI_INT / CLI_FLOAT / CLI_OPT_INT range */
    int *set;           /* also stores setval here when the option is seen (may be NULL) */
    int setval;
} cli_option;

/* Table entries (designated initializers, so unused fields stay zero). */
#define CLI_S(n, p) { .name = (n), .kind = CLI_STR, .out = (p) }
#define CLI_I(n, p, a, b) { .name = (n), .kind = CLI_INT, .out = (p), .lo = (a), .hi = (b) }
#define CLI_F(n, p, a, b) { .name = (n), .kind = CLI_FLOAT, .out = (p), .lo = (a), .hi = (b) }
#define CLI_WH(n, p) { .name = (n), .kind = CLI_SIZE, .out = (p) }
#define CLI_B(n, p) { .name = (n), .kind = CLI_FLAG, .out = (p) }
#define CLI_SETV(n, p, v) { .name = (n), .kind = CLI_SET, .set = (p), .setval = (v) }
#define CLI_OI(n, p, a, b, sp, sv) { .name = (n), .kind = CLI_OPT_INT, .out = (p), .lo = (a), .hi = (b), .set = (sp), .setval = (sv) }
#define CLI_END { .name = NULL }

/* Parses argv[1..argc) against opts. Arguments that are not options go to pos[] (at most
 * maxpos; more is a usage error). Returns 0 (parsed), 1 (--help seen: the caller prints its
 * help and exits 0) or 2 (usage error, already printed as one line). */
int cli_parse(const char *cmd, int argc, char **argv, const cli_option *opts, const char **pos, int maxpos, int *npos);

/* Prints "prt CMD: message" to stderr; returns 1. */
int cli_error(const char *cmd, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* True for -h / --help. */
bool cli_is_help(const char *a);
/* --backend NAME (render, bench, view): its entry of the runtime's table (runtime.h) when it has every
 * capability in need (0: any; what: those in words, "draw into a window"), else NULL after printing one
 * line naming the backends that fit (a usage error, exit 2). */
struct runtime_backend_info;
const struct runtime_backend_info *cli_backend(const char *cmd, const char *name, unsigned need, const char *what);
/* Prints --backend's help, its words from column col: the names of the backends with every capability
 * in need and the default dflt, then one line per backend, its summary (in this build). */
void cli_backend_help(int col, unsigned need, const char *dflt);
#endif

/* Shared by render / view / reference: loading a probe with warnings, and the light vector. */
#include "probe.h"
/* Loads a probe (layout name or NULL for auto), printing one warning line per clamped kind. Returns 0 or 1 (error printed). */
int cli_load_probe(const char *cmd, const char *path, const char *layout, prt_probe *out);
/* The exposure of an image written to out: the --exposure given (finite), else the probe's under
 * rotation R (probe_exposure: render and reference agree), said on stderr when out is tone-mapped. */
float cli_exposure(float given, const prt_probe *probe, const float R[9], const char *out);
/* Every output a command writes is checked before any loading or computing: the name is not
 * empty, its folder exists and is writable, its extension is one the writer makes (kind:
 * CLI_OUT_IMAGE an image format image_write supports, CLI_OUT_PRT ".prt", CLI_OUT_CSV ".csv"),
 * and it is not the same file (prt_same_file) as any input the command reads nor as another of
 * its outputs, so that no command overwrites what it reads. Also removes the outputs' temporaries
 * left by killed runs (prt_atomic_clean), saying so in one line. */
#define CLI_OUT_ANY 0
#define CLI_OUT_IMAGE 1
#define CLI_OUT_PRT 2
#define CLI_OUT_CSV 3
typedef struct cli_output {
    const char *role;   /* how the user named it: "-o", "--vertices" */
    const char *path;   /* NULL: not asked for (skipped) */
    int kind;           /* CLI_OUT_* */
} cli_output;
/* The files a command reads, gathered before any work (each path copied). */
typedef struct cli_inputs {
    int n, cap;
    bool oom;           /* a path could not be kept: cli_check_files says so */
    char **path;
    char **role;        /* "--probe", "an OBJ named by scene.json"; NULL: the command's own input */
} cli_inputs;
/* Adds path (NULL, "" and "none" add nothing: no file). */
void cli_inputs_add(cli_inputs *ins, const char *role, const char *path);
/* Adds each path of a comma-separated list (--light-prior P1,P2). */
void cli_inputs_add_list(cli_inputs *ins, const char *role, const char *list);
/* Adds a scene (OBJ or JSON) and, for a JSON scene, every file it names: its models' "obj" files
 * and its "light_prior" probes, relative to its folder as scene_load reads them (a JSON that does
 * not parse adds only itself: the loader reports it). */
void cli_inputs_add_scene(cli_inputs *ins, const char *path);
/* Frees what ins holds and empties it. */
void cli_inputs_free(cli_inputs *ins);
/* Checks the nout outputs as above and then the inputs (none may be a directory); frees ins.
 * Returns 0, or 2 (a usage error; 1 when ins ran out of memory) after printing one line that
 * names the path(s). */
int cli_check_files(const char *cmd, const cli_output *outs, int nout, cli_inputs *ins);
/* One output of a command that reads no file (cli_check_files with no inputs; NULL is an empty name). */
int cli_check_output(const char *cmd, const char *path, int kind);
/* --light-rotation: fills R from "YAW[,PITCH]" (NULL s: identity). Returns 0, or 1 after printing the error. */
int cli_rotation(const char *cmd, const char *s, float R[9]);
/* The camera every command uses (render, reference, view, bench): the scene's camera named
 * cam_name (--camera-name; NULL: the first the file keeps, a glTF's, asset.h), else the models
 * framed (scene_focus_bounds + camera_default); overridden by --camera cam_s when given, so a
 * reference and a PRT render of one file see the same view. Returns 0, or 2 (a usage error) after
 * printing one line: no camera of that name (the file's names listed), bad syntax, or an eye on the
 * target (the given one, or with an eye alone the one the framing picked: "the eye and the target
 * coincide"). */
#include "camera.h"
#include "scene.h"
#include "prtfile.h"
/* --layout and --camera checked before any loading (usage errors, exit 2):
 * layout a probe layout name, cam_s numbers as camera_parse takes them (NULL: not given).
 * Returns 0, or 2 after printing one line. */
int cli_check_view_flags(const char *cmd, const char *layout, const char *cam_s);
int cli_camera(const char *cmd, const prt_scene *s, float aspect, const char *cam_s, const char *cam_name, prt_camera *out);
/* Local lights (render, reference, bench, view): takes every "--light SPEC"
 * (lights.h: point:pos=x,y,z;intensity=I;colour=r,g,b or spot:...;dir=..;inner=..;outer=..)
 * and "--no-file-lights" out of argv (argc shrinks) into extra / no_file. --probe none is
 * a black environment (local lights alone). Returns 0, or 2 after printing one line. */
int cli_take_lights(const char *cmd, int *argc, char **argv, prt_lights *extra, bool *no_file);
/* The scene's lights: the file's (none with no_file) then extra. 0, or 2 after printing. */
int cli_apply_lights(const char *cmd, prt_scene *s, const prt_lights *extra, bool no_file);
/* The runtimes' indirect local light (indirect.h, glvsgl.h) as the command line asks: each -1 (not
 * said: the effects the file was made for, effects.h), 0 off or on (samples: rays per glossy vertex). */
typedef struct cli_indirect {
    int bounce;     /* --local-bounce 1, --no-local-bounce 0 */
    int samples;    /* --highlights 32, --highlight-samples N (1..1024), --no-highlights 0 */
} cli_indirect;
/* Takes those flags out of argv (argc shrinks) into *out. Returns 0, or 2 after printing one line. */
int cli_take_indirect(const char *cmd, int *argc, char **argv, cli_indirect *out);
/* What to run for d (its lights applied): the flags, else the file's effects (prt_file_effects), said
 * on stderr unless quiet when the file turned one on. */
void cli_indirect_resolve(const cli_indirect *in, const prt_data *d, bool quiet, int *samples, bool *bounce);
#define CLI_INDIRECT_HELP \
    "  --local-bounce          the local lights' one bounce (two VSGLs per light; cpu per vertex, gl per pixel);\n" \
    "                          default: as the file's effects plan decided (--no-local-bounce: off)\n" \
    "  --highlights            their indirect highlights (32 rays per glossy vertex, on the CPU; gl adds them);\n" \
    "                          default: as the file's effects plan decided (--no-highlights: off)\n" \
    "  --highlight-samples N   the same with N rays (1..1024)\n"
/* --aa N (render, view, bench): antialiasing samples per pixel (render_desc.samples: multisampled, averaged
 * in linear radiance); CLI_AA_DEFAULT when not given, 1 turns it off. */
#define CLI_AA_DEFAULT 4
#define CLI_AA_MAX 16
#define CLI_STR_(x) #x
#define CLI_XSTR(x) CLI_STR_(x)
#define CLI_AA_HELP \
    "  --aa N                  antialiasing: N samples per pixel (multisampling; default " CLI_XSTR(CLI_AA_DEFAULT) ", 1: off;\n" \
    "                          at most " CLI_XSTR(CLI_AA_MAX) ", or what the GL implementation allows)\n"
/* The help lines of those flags. */
#define CLI_LIGHT_HELP \
    "  --light SPEC            add a local light: point:pos=x,y,z;intensity=W/sr;colour=r,g,b or\n" \
    "                          spot:pos=..;dir=..;inner=DEG;outer=DEG;intensity=..;colour=.. (repeatable)\n" \
    "  --no-file-lights        ignore the lights stored in the file (keep only --light ones)\n"


