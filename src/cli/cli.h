/* cli.h - the prt command's subcommands. Each is int cli_NAME(int argc, char **argv)
 * in src/cli/cli_NAME.c, called by src/cli/main.c with argv[0] = the subcommand name.
 * Each returns the process exit status (0 ok, 1 error, 2 usage), prints errors as
 * one line "prt NAME: message" on stderr, and answers --help / -h with its usage. */
#ifndef PRT_CLI_H
#define PRT_CLI_H
int cli_precompute(int argc, char **argv);
int cli_render(int argc, char **argv);
int cli_info(int argc, char **argv);
int cli_demo(int argc, char **argv);
int cli_brdf(int argc, char **argv);
int cli_view(int argc, char **argv);
int cli_reference(int argc, char **argv);
int cli_compare(int argc, char **argv);
int cli_bench(int argc, char **argv);
#endif
