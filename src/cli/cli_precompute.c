/* cli_precompute.c - `prt precompute`: scene -> precompute pipeline -> .prt file,
 * with a progress bar and a per-stage timing summary. */
#include "cli.h"
#include "cli_args.h"
#include "precompute.h"
#include "prtfile.h"
#include "refine.h"
#include "scene.h"
#include "shard.h"
#include "driver.h"
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const char *k_cmd = "precompute";

/* The help of option o of a representation, in the columns of the rest (flag, then its text from
 * column 25). */
static void help_option(const transfer_option *o) {
    char first[96];
    snprintf(first, sizeof first, "%s%s%s", o->flag, o->arg ? " " : "", o->arg ? o->arg : "");
    const char *h = o->help ? o->help : "";
    int n = (int)strcspn(h, "\n");
    if (strlen(first) <= 22) printf("  %-22s %.*s\n", first, n, h);
    else printf("  %s  %.*s\n", first, n, h);
    for (h += n; *h == '\n'; h += n) {
        h++;
        n = (int)strcspn(h, "\n");
        printf("%25s%.*s\n", "", n, h);
    }
}

/* Every flag the representations of kind declare (their option tables), in table order. */
static void help_kind(transfer_kind kind) {
    for (int i = 0; i < transfer_count(); i++)
        if (transfer_at(i)->kind == kind)
            for (const transfer_option *o = transfer_at(i)->options; o && o->key; o++)
                if (o->flag) help_option(o);
}

/* The representations of kind as "name (title), ...", the default marked. */
static void help_names(transfer_kind kind, char *buf, size_t cap) {
    size_t at = 0;
    buf[0] = 0;
    for (int i = 0; i < transfer_count() && at < cap; i++) {
        const transfer_ops *t = transfer_at(i);
        if (t->kind == kind)
            at += (size_t)snprintf(buf + at, cap - at, "%s%s (%s%s)", at ? ", " : "", t->name, t->title,
                                   t == transfer_default(kind) ? ", the default" : "");
    }
}

static void help(void) {
    char lin[512], view[512];
    help_names(TRANSFER_LINEAR, lin, sizeof lin);
    help_names(TRANSFER_VIEW, view, sizeof view);
    fputs("usage: prt precompute MODEL.obj|.gltf|.glb|.ply|SCENE.json -o OUT.prt [options]\n"
         "\n"
         "scene:\n"
         "  --material SPEC        BRDF of every model, replacing a glTF's or MTL's own materials (default: the\n"
         "                         file's, else lambert:kd=0.8); see `prt brdf --help`\n"
         "models: OBJ (an OBJ naming an MTL library: its materials and map_Kd textures), glTF 2.0 (.gltf,\n"
         "  .glb: metallic-roughness materials onto GGX, base-colour textures, KHR_lights_punctual point and\n"
         "  spot lights, cameras for render/view/reference's --camera-name), PLY; what is left out is noted\n"
         "  --floor [VERTS]        add a diffuse floor under the model (default 31000 vertices)\n"
         "  --no-floor             no floor even if the JSON scene has one\n"
         "  --floor-material SPEC  floor BRDF (default lambert:kd=0.7)\n"
         "BRDF factorization (section 3.3):\n"
         "  --terms K              BRDF terms for glossy materials, the cap (default 4; Lambert always 1)\n"
         "  --term-error E         smallest K whose relative BRDF error is <= E (capped by --terms;\n"
         "                         default: off, K = --terms)\n"
         "  --polar                polar parameterization (Eq. 11) instead of the uniform grid (Eq. 10)\n"
         "transport (section 4.1):\n"
         "  --coeffs N             wavelet coefficients kept per transport vector (default 128)\n"
         "  --quant 8|16|32        coefficient quantization bits (default 8; 32 = float)\n"
         "  --vis-res R            visibility cube resolution: 64, 128 (default; 2x2 supersampling) or 256\n"
         , stdout);
    printf("  --basis NAME           the linear representation: %s\n"
           "  --basis-options K=V,...  its options as text, key=value (the flags below set them too)\n", lin);
    fputs("  --light-prior PROBE[,PROBE...]  weigh the expected-error selection by PROBE's light: each\n"
          "                         coefficient by its RMS as PROBE turns about +y (the viewer's yaw), so\n"
          "                         a shadow edge keeps its detail where the probe's sun can be (README\n"
          "                         \"Shadows\"; the file serves any probe, best the ones named); a\n"
          "                         list weighs each probe the same. Default: none, or the probes a JSON\n"
          "                         scene's \"light_prior\" key names (unless this flag or the next says\n"
          "                         otherwise)\n"
          "  --no-light-prior       not the scene's light_prior: the per-level weights\n", stdout);
    help_kind(TRANSFER_LINEAR);
    printf("glossy materials (the effects plan prints each material's path and why):\n"
           "  --glossy auto|svd|NAME  auto (default): the SVD where its error at K is <= 10%%, else the linear\n"
           "                         K = 1 diffuse + the default view-dependent representation's specular\n"
           "                         lobes (laurijssen-2011); svd: always the SVD; NAME: that view-dependent\n"
           "                         representation wherever it fits the BRDF. They are: %s\n"
           "  --view-options K=V,...  its options as text, key=value (the flags below set them too)\n", view);
    help_kind(TRANSFER_VIEW);
    fputs(
         "interreflections (section 3.2, 4.2):\n"
         "  --bounces B            at most B interreflection passes (default 3, stopped by the energy\n"
         "                         threshold; 0: none)\n"
         "  --gather-res R         gathering cube resolution (default 32)\n"
         "  --bounce-threshold T   stop when a pass carries < T of the direct energy (default 0.01)\n"
         "  --force-bounces        do all B passes even if the plan would skip them\n"
         "  --no-bounces           never do interreflection passes\n"
         "  --keep-direct          also store the direct-only transport (for render --direct-only and\n"
         "                         the viewer's direct/bounces toggle; about doubles the file)\n"
         "  --no-open-sky          store Lambertian transport whole (default: the open sky is added exactly at\n"
         "                         runtime and the coefficients hold only what occluders block)\n"
         "  --no-fold              keep the floor's cosine in its coefficients (default, without interreflections:\n"
         "                         the light takes it, so a low sun's shadow keeps its shape)\n"
         "local lights (a JSON scene's \"lights\"; the plan measures what their indirect light carries):\n"
         "  --local-bounce, --no-local-bounce   plan the local lights' one bounce (two VSGLs) or not\n"
         "                         (default: where it carries >= 2% of their direct light, measured)\n"
         "  --highlights, --no-highlights       plan their indirect highlights or not (default: where\n"
         "                         glossy surfaces receive >= 2% of the direct light by one bounce)\n"
         "adaptive refinement (Laurijssen et al. 2011, section 6.1): by default the models' edges where\n"
         "visibility changes, up to 2.5x their vertices within the file's byte budget (96 MB); then the\n"
         "floor's, up to 2.5x, where its vertex spacing is wider than a sun's penumbra from the models'\n"
         "height and its shadows are folded (no interreflections); else when asked for here or by a JSON\n"
         "scene's \"refine\":\n"
         "  --refine-auto          refine the floor where the plan finds it wider than that penumbra\n"
         "  --refine               before the transport, split the edges whose vertices' visibility\n"
         "                         masks differ in more than 0.5% of directions, iteratively\n"
         "  --refine-threshold F   that share, 0 < F < 1 (default 0.005; turns refinement on; 0: off)\n"
         "  --refine-budget V      at most V vertices after refinement (default 1.5x the scene's; turns it on)\n"
         "  --refine-models        refine the models' edges too (default: the floor's, where there is one)\n"
         "  --no-refine            no refinement: not the models', --refine-auto's or a JSON scene's\n"
         "                         \"refine\" (any refine flag replaces the scene's and the models'\n"
         "                         default)\n"
         "other:\n"
         "  --resume               continue the run killed while writing OUT.prt from its checkpoint\n"
         "                         OUT.prt.ckpt (written every 2% of the vertices of each pass, removed\n"
         "                         on success); the file is the one an uninterrupted run writes\n"
         "  --threads T            worker threads (default: all cores; the file does not depend on it)\n"
         "  --memory GB            memory budget: above half of it the direct pass streams its finished\n"
         "                         vectors through a temporary file beside OUT.prt (default: half of\n"
         "                         this machine's memory; the file is the same)\n"
         "  --quiet                no progress output\n"
         "\n"
         "Under mpirun or srun (README \"Running on a cluster\") the passes are split across the ranks,\n"
         "rank 0 writes OUT.prt (the same file as one process) and --resume is refused.\n", stdout);
}

/* Under MPI, each split pass's balance (shard_balance): the items, wall and CPU time of every
 * rank (of the fastest and slowest beyond 16 ranks), and the slowest rank's wall time over the mean. */
static void balance(const prt_shard *sh) {
    int P = shard_size(sh);
    const char *name, *unit;
    const shard_rank_stats *b;
    if (P > 1 && shard_balance(sh, 0, &name, &unit)) fprintf(stderr, "balance over %d ranks\n", P);
    for (int i = 0; (b = shard_balance(sh, i, &name, &unit)); i++) {
        long n = 0;
        double sum = 0;
        int fast = 0, slow = 0;
        for (int r = 0; r < P; r++) {
            n += b[r].items, sum += b[r].seconds;
            if (b[r].seconds < b[fast].seconds) fast = r;
            if (b[r].seconds > b[slow].seconds) slow = r;
        }
        fprintf(stderr, "  %s: %ld %s, slowest rank %.2fx the mean time\n", name, n, unit, sum > 0 ? b[slow].seconds * P / sum : 1.0);
        for (int r = 0; r < P; r++)
            if (P <= 16 || r == fast || r == slow)
                fprintf(stderr, "    rank %-4d %10ld %-8s %9.2fs %9.2fs CPU\n", r, b[r].items, unit, b[r].seconds, b[r].cpu);
    }
}

/* One line of the timing summary: the stage and its time as a person reads it (tools/bench.sh
 * reads the figure back: "850 ms", "1.7 s", "2 min 05 s", "1 h 02 min"). */
static void stage_line(const char *name, double seconds) {
    char t[48];
    prt_format_duration(t, sizeof t, seconds);
    fprintf(stderr, "  %-28s %12s\n", name, t);
}

/* The per-stage timing summary, the ranks' balance and the closing line (stderr). */
static void summary(const char *out, const prt_data *data, const prt_shard *sh, double t_load, double t0) {
    struct stat st;
    double mb = stat(out, &st) == 0 ? st.st_size / 1e6 : 0;
    const prt_stats *s = &data->stats;
    fprintf(stderr, "\ntiming summary\n");
    stage_line("scene load", t_load);
    for (int i = 0; i < data->ntransfers; i++)   /* a representation's own setup (Haar: its light prior) */
        if (s->t_transfer_name[i]) stage_line(s->t_transfer_name[i], s->t_transfer[i]);
    if (s->t_refine > 0) stage_line("refinement", s->t_refine);
    stage_line("BRDF factorization", s->t_brdf);
    stage_line("visibility (ray casting)", s->t_visibility);
    stage_line("transport+wavelet+quant.", s->t_transport);
    for (int b = 0; b < s->bounces && b < PRT_MAX_BOUNCES; b++) {
        char name[64];
        snprintf(name, sizeof name, "bounce %d (%.2f%% energy)", b + 1, 100 * s->bounce_energy[b]);
        stage_line(name, s->t_bounce[b]);
    }
    for (int i = 0; i < data->ntransfers; i++)
        if (data->transfers[i].ops->kind == TRANSFER_VIEW && s->t_transfer[i] > 0) {
            char name[64];
            snprintf(name, sizeof name, "%s lobes (all passes)", data->transfers[i].ops->label);
            stage_line(name, s->t_transfer[i]);
        }
    stage_line("writing", s->t_write);
    stage_line("total", prt_now() - t0);
    balance(sh);
    const prt_transport *t = &prt_data_transfer(data)->transport;
    fprintf(stderr, "wrote %s: %.1f MB, %d vertices, %d transport vectors, N = %d, %d-bit", out, mb, t->nverts,
            t->nvecs, t->budget ? t->budget : t->N, t->qbits);
    if (t->budget) fprintf(stderr, ", shared (a vector up to %d)", t->N);
    for (int i = 0; i < data->ntransfers; i++)
        if (data->transfers[i].ops->kind == TRANSFER_VIEW)
            fprintf(stderr, "; %s %.1f MB", data->transfers[i].ops->name, data->transfers[i].ops->bytes(&data->transfers[i]) / 1e6);
    fputc('\n', stderr);
}

/* What the timing summary needs besides the file's data (driver.h's done callback). */
typedef struct cli_pc_done {
    const char *out;
    prt_bar *bar;
    bool quiet;
    double t0;      /* when the command's work began */
} cli_pc_done;

/* precompute_file's done: the bar's last line, then the timing summary (rank 0, unless quiet). */
static void on_done(void *user, const prt_data *data, const prt_shard *sh, double t_load) {
    cli_pc_done *u = user;
    prt_bar_done(u->bar);
    if (!u->quiet) summary(u->out, data, sh, t_load, u->t0);
}

/* Runs the job (the scene's keys the command line leaves to it: scene_keys) with a progress bar and
 * the timing summary. Returns the exit status. */
static int run(const char *in, const char *out, const scene_desc *sd, precompute_desc *pd, bool quiet, unsigned scene_keys) {
    prt_error err = { { 0 } };
    prt_bar bar;
    prt_bar_init(&bar, stderr, quiet);
    pd->progress = prt_bar_report;
    pd->progress_user = &bar;
    cli_pc_done u = { .out = out, .bar = &bar, .quiet = quiet, .t0 = prt_now() };
    precompute_job job = { .scene_path = in, .scene = sd, .out_path = out, .scene_keys = scene_keys, .checkpoint = true,
                           .quiet = quiet, .done = on_done, .done_user = &u };
    precompute_outcome o;
    int rc = precompute_file(&job, pd, &o, &err);
    prt_bar_done(&bar);
    if (rc && o.say) cli_error(k_cmd, "%s", err.msg);
    return rc ? o.status : 0;
}

/* The representations' flags (their option tables, transfer.h): each seen flag is one "key=value" of
 * its representation's options text. */
#define REP_FLAGS 64
typedef struct rep_flags {
    int n;
    const transfer_ops *ops[REP_FLAGS];
    const transfer_option *opt[REP_FLAGS];
    const char *word[REP_FLAGS];    /* WORD: the argument */
    int num[REP_FLAGS];             /* INT: the argument */
    bool on[REP_FLAGS];             /* SWITCH: given */
    int seen[REP_FLAGS];
} rep_flags;

/* Appends one cli_option per representation flag to opts (from at, cap in all); returns the new count. */
static int rep_flag_options(rep_flags *rf, cli_option *opts, int at, int cap) {
    for (int i = 0; i < transfer_count(); i++)
        for (const transfer_option *o = transfer_at(i)->options; o && o->key; o++) {
            if (!o->flag || rf->n == REP_FLAGS || at + 1 >= cap) continue;
            int k = rf->n++;
            rf->ops[k] = transfer_at(i), rf->opt[k] = o;
            cli_option *c = &opts[at++];
            if (o->kind == TRANSFER_OPT_SWITCH) *c = (cli_option)CLI_B(o->flag, &rf->on[k]);
            else if (o->kind == TRANSFER_OPT_INT) *c = (cli_option)CLI_I(o->flag, &rf->num[k], o->lo, o->hi);
            else *c = (cli_option)CLI_S(o->flag, &rf->word[k]);
            c->set = &rf->seen[k], c->setval = 1;
        }
    opts[at] = (cli_option)CLI_END;
    return at;
}

/* "a, b or c" from the words "a|b|c". */
static void words_or(const char *w, char *buf, size_t cap) {
    size_t at = 0;
    buf[0] = 0;
    for (int k = 0; *w && at < cap; k++) {
        size_t n = strcspn(w, "|");
        bool last = !w[n];
        at += (size_t)snprintf(buf + at, cap - at, "%s%.*s", k == 0 ? "" : last ? " or " : ", ", (int)n, w);
        w += n + !last;
    }
}

/* Representation ops: the options text of its flags seen (rf), then extra (--basis-options and the like),
 * into text[cap]; a WORD flag's argument is checked against its words. Returns 0, or 2 after saying why. */
static int rep_text(const rep_flags *rf, const transfer_ops *ops, const char *extra, char *text, size_t cap) {
    size_t at = 0;
    text[0] = 0;
    for (int k = 0; k < rf->n; k++) {
        if (rf->ops[k] != ops || !rf->seen[k]) continue;
        const transfer_option *o = rf->opt[k];
        prt_error err;
        if (o->kind == TRANSFER_OPT_WORD && transfer_option_word(ops->name, o, rf->word[k], &err) < 0) {
            char w[256];
            words_or(o->words, w, sizeof w);
            return cli_error(k_cmd, "%s must be %s (got '%s')", o->flag, w, rf->word[k]) + 1;
        }
        if (o->kind == TRANSFER_OPT_SWITCH) at += (size_t)snprintf(text + at, at < cap ? cap - at : 0, "%s=%s,", o->key, o->value);
        else if (o->kind == TRANSFER_OPT_INT) at += (size_t)snprintf(text + at, at < cap ? cap - at : 0, "%s=%d,", o->key, rf->num[k]);
        else at += (size_t)snprintf(text + at, at < cap ? cap - at : 0, "%s=%s,", o->key, rf->word[k]);
    }
    if (extra) at += (size_t)snprintf(text + at, at < cap ? cap - at : 0, "%s", extra);
    return at < cap ? 0 : cli_error(k_cmd, "%s options: too long", ops->name) + 1;
}

/* The representation of kind the flags chose: --basis / --glossy's name (named), else one whose
 * selecting flag was seen (--sh), else the table's default (none: NULL). An unknown name is refused
 * listing the alternatives (also: the other words named_by takes, '|'-separated), and so are the
 * flags of another representation of that kind ("--texel-measure applies to Haar wavelets, not
 * --sh"). Returns 0, or 2 after saying why. */
static int rep_choose(const rep_flags *rf, transfer_kind kind, const char *named, const char *named_by, const char *also,
                      const transfer_ops **out) {
    char how[128] = "";
    *out = NULL;
    if (named) {
        *out = transfer_find(named);
        if (!*out || (*out)->kind != kind) {
            char names[256], w[300];
            snprintf(names, sizeof names, "%s", also);
            for (int i = 0; i < transfer_count(); i++)
                if (transfer_at(i)->kind == kind)
                    snprintf(names + strlen(names), sizeof names - strlen(names), "%s%s", names[0] ? "|" : "", transfer_at(i)->name);
            words_or(names, w, sizeof w);
            return cli_error(k_cmd, "%s must be %s (got '%s')", named_by, w, named) + 1;
        }
        snprintf(how, sizeof how, "%s %s", named_by, named);
    }
    for (int k = 0; k < rf->n; k++)
        if (rf->seen[k] && rf->opt[k]->selects && rf->ops[k]->kind == kind) {
            if (*out && *out != rf->ops[k]) return cli_error(k_cmd, "%s and %s contradict each other", rf->opt[k]->flag, how) + 1;
            *out = rf->ops[k];
            snprintf(how, sizeof how, "%s", rf->opt[k]->flag);
        }
    if (!*out) *out = transfer_default(kind), snprintf(how, sizeof how, "the default %s", *out ? (*out)->name : "");
    for (int k = 0; k < rf->n; k++)
        if (rf->seen[k] && rf->ops[k]->kind == kind && rf->ops[k] != *out)
            return cli_error(k_cmd, "%s applies to %s, not %s", rf->opt[k]->flag, rf->ops[k]->title, how) + 1;
    return 0;
}

/* The command line's representations into pd: --basis / its flags / --basis-options, and --glossy /
 * the view-dependent flags / --view-options; texts hold their options (they must outlive pd's use).
 * Then pd checked as precompute will (every option of both). Returns 0, or 2 after saying why. */
static int rep_desc(const rep_flags *rf, const char *basis, const char *basis_opts, const char *glossy, const char *view_opts,
                    precompute_desc *pd, char (*texts)[1024]) {
    const transfer_ops *lin, *view;
    bool named_view = glossy && strcmp(glossy, "auto") && strcmp(glossy, "svd");
    if (rep_choose(rf, TRANSFER_LINEAR, basis, "--basis", "", &lin) ||
        rep_choose(rf, TRANSFER_VIEW, named_view ? glossy : NULL, "--glossy", "auto|svd", &view))
        return 2;
    if (rep_text(rf, lin, basis_opts, texts[0], sizeof texts[0]) || (view && rep_text(rf, view, view_opts, texts[1], sizeof texts[1])))
        return 2;
    pd->basis = basis || lin != transfer_default(TRANSFER_LINEAR) ? lin->name : NULL;
    pd->basis_options = texts[0][0] ? texts[0] : NULL;
    pd->glossy = !glossy || !strcmp(glossy, "auto") ? PRECOMPUTE_GLOSSY_AUTO : !strcmp(glossy, "svd") ? PRECOMPUTE_GLOSSY_SVD
                                                                                                   : PRECOMPUTE_GLOSSY_VIEW;
    pd->view = named_view ? view->name : NULL;
    pd->view_options = view && texts[1][0] ? texts[1] : NULL;
    prt_error err;
    if (precompute_desc_check(pd, &err)) {
        const char *m = strncmp(err.msg, "precompute: ", 12) ? err.msg : err.msg + 12;
        return cli_error(k_cmd, "%s", m) + 1;
    }
    return 0;
}

/* The light prior's probe files (--light-prior's comma-separated list, already checked by
 * precompute_desc_check) read before any work, so that a bad one is one line: each loaded as
 * render's --probe is, with its warnings, and freed (the representation loads them again). Returns 0,
 * or 1 after saying why. */
static int check_prior_probes(const char *list) {
    for (const char *s = list; *s;) {
        size_t len = strcspn(s, ",");
        char path[4096];
        snprintf(path, sizeof path, "%.*s", (int)len, s);
        prt_probe p;
        if (cli_load_probe(k_cmd, path, NULL, &p)) return 1;
        probe_free(&p);
        s += len + (s[len] == ',');
    }
    return 0;
}

int cli_precompute(int argc, char **argv) {
    const char *in = NULL, *out = NULL;
    scene_desc sd = { .floor = -1 };
    precompute_desc pd = { 0 };
    bool quiet = false;
    int param = BRDF_PARAM_GRID, refine = 0, bounces_seen = 0;
    const char *glossy = NULL, *prior = NULL, *basis = NULL, *basis_opts = NULL, *view_opts = NULL;
    float refine_thr = -1;
    bool no_prior = false;
    rep_flags rf;   /* the representations' flags */
    memset(&rf, 0, sizeof rf);
    cli_option opts[48 + REP_FLAGS] = {
        CLI_S("-o", &out),
        CLI_S("--material", &sd.material),
        CLI_S("--floor-material", &sd.floor_material),
        CLI_OI("--floor", &sd.floor_verts, 4, 4000000, &sd.floor, 1),
        CLI_SETV("--no-floor", &sd.floor, 0),
        CLI_SETV("--polar", &param, BRDF_PARAM_POLAR),
        CLI_SETV("--force-bounces", &pd.force_bounces, 1),
        CLI_SETV("--no-bounces", &pd.force_bounces, -1),
        CLI_B("--keep-direct", &pd.keep_direct),
        CLI_B("--no-open-sky", &pd.no_open_sky),
        CLI_B("--no-fold", &pd.no_fold),
        CLI_SETV("--local-bounce", &pd.force_local_bounce, 1),
        CLI_SETV("--no-local-bounce", &pd.force_local_bounce, -1),
        CLI_SETV("--highlights", &pd.force_highlights, 1),
        CLI_SETV("--no-highlights", &pd.force_highlights, -1),
        CLI_SETV("--refine", &refine, 1),
        CLI_SETV("--no-refine", &refine, -1),
        CLI_SETV("--refine-auto", &pd.force_refine, 1),
        CLI_F("--refine-threshold", &refine_thr, 0, 1),
        CLI_I("--refine-budget", &pd.refine_budget, 4, 1 << 28),
        CLI_SETV("--refine-models", &pd.refine_parts, REFINE_ALL),
        CLI_B("--quiet", &quiet),
        CLI_I("--terms", &pd.max_terms, 1, 64),
        CLI_F("--term-error", &pd.term_error, 1e-6, 1),
        CLI_I("--coeffs", &pd.N, 1, 24576),
        CLI_I("--quant", &pd.qbits, 8, 32),
        CLI_I("--vis-res", &pd.vis_res, 64, 256),
        CLI_S("--basis", &basis),
        CLI_S("--basis-options", &basis_opts),
        CLI_S("--light-prior", &prior),
        CLI_B("--no-light-prior", &no_prior),
        { .name = "--bounces", .kind = CLI_INT, .out = &pd.bounces, .lo = 0, .hi = PRT_MAX_BOUNCES, .set = &bounces_seen, .setval = 1 },
        CLI_S("--glossy", &glossy),
        CLI_S("--view-options", &view_opts),
        CLI_I("--gather-res", &pd.gather_res, 4, 128),
        CLI_F("--bounce-threshold", &pd.bounce_threshold, 0, 1),
        CLI_I("--threads", &pd.nthreads, 1, 64),
        CLI_B("--resume", &pd.resume),
        CLI_F("--memory", &pd.memory_gb, 0.0001, 1e6),
        CLI_END,
    };
    int nopts = 0;
    while (opts[nopts].name) nopts++;
    rep_flag_options(&rf, opts, nopts, (int)(sizeof opts / sizeof opts[0]));
    int npos = 0, pr = cli_parse(k_cmd, argc, argv, opts, &in, 1, &npos);
    if (pr == 1) { help(); return 0; }
    if (pr) return 2;
    pd.param = (brdf_param)param;
    if (prior && no_prior) return cli_error(k_cmd, "--light-prior and --no-light-prior contradict each other") + 1;
    pd.light_prior = prior;
    /* --bounces 0 turns interreflections off (the library's 0 means its default, 3) */
    if (bounces_seen && pd.bounces == 0 && pd.force_bounces == 0) pd.force_bounces = -1;
    if (pd.qbits && pd.qbits != 8 && pd.qbits != 16 && pd.qbits != 32) return cli_error(k_cmd, "--quant must be 8, 16 or 32") + 1;
    if (pd.vis_res && pd.vis_res != 64 && pd.vis_res != 128 && pd.vis_res != 256)
        return cli_error(k_cmd, "--vis-res must be 64, 128 or 256") + 1;
    if (refine_thr >= 1) return cli_error(k_cmd, "--refine-threshold must be below 1 (a share of directions)") + 1;
    /* on when asked for by any refine flag; a threshold of 0 or --no-refine turns it off */
    if (refine != -1 && refine_thr != 0 && (refine == 1 || refine_thr > 0 || pd.refine_budget > 0 || pd.refine_parts))
        pd.refine_threshold = refine_thr > 0 ? refine_thr : REFINE_THRESHOLD;
    if (pd.force_refine == 1 && (refine == -1 || refine_thr == 0))
        return cli_error(k_cmd, "--refine-auto and --no-refine (or --refine-threshold 0) contradict each other") + 1;
    if (refine == -1 || refine_thr == 0) pd.force_refine = -1;   /* the plan's refinement too */
    char texts[2][1024];   /* the representations' options texts; pd points at them until run returns */
    if (rep_desc(&rf, basis, basis_opts, glossy, view_opts, &pd, texts)) return 2;
    if (!in) { cli_error(k_cmd, "no input model or scene (see --help)"); return 2; }
    if (!out) { cli_error(k_cmd, "no output file (-o OUT.prt)"); return 2; }
    /* the file, its checkpoint (written during the run) and every file the run reads, before any work */
    char ck[4200];
    snprintf(ck, sizeof ck, "%s.ckpt", out);
    const cli_output outs[] = { { "-o", out, CLI_OUT_PRT }, { "its checkpoint", ck, CLI_OUT_ANY } };
    cli_inputs ins = { 0 };
    cli_inputs_add_scene(&ins, in);
    cli_inputs_add_list(&ins, "--light-prior", prior);
    if (cli_check_files(k_cmd, outs, 2, &ins)) return 2;
    /* --material / --floor-material are flags: a bad spec is a usage error, found before loading */
    const char *specs[2] = { sd.material, sd.floor_material };
    for (int i = 0; i < 2; i++) {
        brdf_params bp;
        prt_error err = { { 0 } };
        if (specs[i] && brdf_parse(specs[i], &bp, &err)) return cli_error(k_cmd, "%s: %s", i ? "--floor-material" : "--material", err.msg) + 1;
    }
    if (prior && check_prior_probes(prior)) return 1;
    /* any refine flag replaces the scene's "refine" (scene.h), --no-refine included; --light-prior and
     * --no-light-prior its "light_prior" */
    const bool scene_refine = refine == 0 && refine_thr < 0 && pd.refine_budget == 0 && !pd.refine_parts;
    const unsigned keys = (!prior && !no_prior ? PRECOMPUTE_SCENE_LIGHT_PRIOR : 0) | (scene_refine ? PRECOMPUTE_SCENE_REFINE : 0);
    return run(in, out, &sd, &pd, quiet, keys);
}
