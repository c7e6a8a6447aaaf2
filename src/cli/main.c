/* main.c - the prt command: dispatches to one subcommand (src/cli/cli_*.c). A build without
 * GL (PRT_NO_GL) lists its GL-only commands without a function: they print one line, exit 2. */
#include "cli.h"
#include "common.h"
#include <stdio.h>
#include <string.h>

typedef struct subcommand { const char *name; int (*fn)(int, char **); const char *what; } subcommand;

static const subcommand k_commands[] = {
    { "precompute", cli_precompute, "precompute transport for an OBJ model or a JSON scene into a .prt file" },
    { "render", cli_render, "relight a .prt file under a light probe and write a PNG or EXR image" },
    { "info", cli_info, "describe a .prt file: sizes, terms, coefficients, timings, effects plan" },
    { "brdf", cli_brdf, "factor a BRDF and print its singular values and error against K" },
    { "demo", cli_demo, "precompute and render the built-in demo scene (writes demo.png)" },
#ifndef PRT_NO_GL
    { "view", cli_view, "interactive relighting viewer (GLFW window)" },
#else
    { "view", NULL, "interactive relighting viewer (not in this build: no GL)" },
#endif
    { "reference", cli_reference, "path-traced reference of a .prt file's scene" },
    { "compare", cli_compare, "compare two EXR images or per-vertex CSV files" },
    { "bench", cli_bench, "time light changes and view changes of a .prt file on a runtime backend (Table II)" },
};

static void usage(FILE *f) {
    fprintf(f, "prt %s - all-frequency precomputed radiance transfer (Wang, Tran & Luebke 2006)\n\n"
               "usage: prt COMMAND [ARGS...]   (prt COMMAND --help for its options)\n\ncommands:\n",
            PRT_VERSION_STRING);
    for (size_t i = 0; i < sizeof k_commands / sizeof k_commands[0]; i++)
        fprintf(f, "  %-11s %s\n", k_commands[i].name, k_commands[i].what);
}

int main(int argc, char **argv) {
    if (argc < 2) { usage(stderr); return 2; }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) { usage(stdout); return 0; }
    if (!strcmp(argv[1], "--version")) { printf("prt %s\n", PRT_VERSION_STRING); return 0; }
    for (size_t i = 0; i < sizeof k_commands / sizeof k_commands[0]; i++)
        if (!strcmp(argv[1], k_commands[i].name)) {
            if (k_commands[i].fn) return k_commands[i].fn(argc - 1, argv + 1);
            fprintf(stderr, "prt %s: this build has no GL (NO_GL=1): the command needs OpenGL and GLFW\n", argv[1]);
            return 2;
        }
    fprintf(stderr, "prt: unknown command '%s' (try prt --help)\n", argv[1]);
    return 2;
}
