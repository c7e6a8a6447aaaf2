/* cli_view.c - `prt view`, the interactive relighting viewer.
 *
 * The viewer is a GLFW window drawn through the runtime interface (runtime.h):
 * one runtime for every backend of the table that draws into a window
 * (RUNTIME_CAP_WINDOW), all sharing the window's context, held by table
 * position: the gl backend (the GPU does both the light change, sparse T x L,
 * and the view change, per-pixel view maps) and the cpu backend (relight.c's
 * per-vertex colours drawn into the same window: the paper's CPU path); key b
 * switches to the next. The first that has the per-pixel view model is the one
 * at start unless --backend says otherwise. Either way the
 * frame is tone-mapped (exposure, clamp, sRGB) onto the window, and the
 * on-screen text (6x13 bitmap font) shows the frame time, the last light-change
 * and view-change times, the probe, K and the exposure. A light change happens
 * only when the probe or its rotation changes (each runtime catches up when it
 * is switched to); orbiting is a view change only, exactly the split the paper
 * times.
 *
 * Local lights: the file's lights plus --light ones; key l picks the next
 * light, alt + left drag (or, after key m, a plain left drag) moves the picked one in
 * the view plane; each move is a local-light move (runtime_set_local_lights: shadow
 * rays on the CPU, shadow cubes on GL), timed in the overlay. Keys o and i turn their one
 * bounce (VSGLs) and indirect highlights on and off (runtime_set_local_effects on both
 * runtimes), where the effects plan has them (view_effects_plan); the overlay shows each
 * effect's time (the bounce's part of the light move, the highlights' of the view change).
 *
 * Probes: each is prepared once (runtime_probe_prepare: its fine cube, from which every rotation of
 * the light is resampled in a few milliseconds, and for a vMF file its prefiltered ladder, seconds)
 * and lent to the runtimes. The first at start; another on a worker thread when it is asked for (keys
 * 1-9, n, p), while the window keeps drawing with the light it has and the overlay says "preparing
 * probe"; the switch happens at the first frame after the worker is done (view_prep says who owns
 * what). The last VIEW_KEEP probes shown stay prepared.
 *
 * Antialiasing: frames are multisampled (--aa, render_desc.samples), but for the frames of a mouse
 * drag, which take one sample per pixel (on a software GL, 4 samples cost the CPU backend's frame
 * about twice its time); the still frame after the drag takes them all.
 *
 * Beside the truth (--truth, view_truth.h, docs/truth.md): the window is three panels of one camera,
 * the PRT frame at a third of the width, the progressive reference of the same scene, probe, rotation
 * and local lights (a worker thread at the lowest priority, restarted when any of them or the camera
 * changes), and their per-pixel relative error with its scale and an error-vs-frame-time plot of the
 * settings tried; the text adds rel_rmse over the pixels the reference covers, its noise, spp and
 * time. Keys c / C cut every sparse set to its n largest coefficients per vector
 * (transport_keep_largest): the cpu runtime reads them at its next light change, the gl runtime is
 * made again with them. The reference and error panels are refreshed at most every
 * VIEW_TRUTH_REFRESH while the frames change (read back, compare, upload), the PRT panel every frame.
 *
 * Scripted use (tests, screenshots): --frames N renders N frames and exits,
 * --screenshot OUT.png saves the last one (linear float target written with
 * image_write, the same tone curve `prt render` uses for PNG). A probe asked for by --keys is waited
 * for before the last frame, so the last frame shows it; the summary then says how long it took and
 * how many frames were drawn meanwhile. */
#include "cli.h"
#include "check.h"
#include "cli_args.h"
#include "effects.h"
#include "gldraw.h"
#include "image.h"
#include "probe.h"
#include "prtfile.h"
#include "runtime.h"
#include "vec3.h"
#include "view_truth.h"
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <dirent.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#define VIEW_MAX_PROBES 64
#define VIEW_MAX_RUNTIMES 8     /* at least runtime_backend_count() */
#define VIEW_KEEP 8             /* probes kept prepared (~6 MB each with a prefiltered ladder) */
#define VIEW_POINTS 32          /* settings the --truth plot keeps */
#define VIEW_TRUTH_REFRESH 0.25 /* seconds between --truth panel refreshes (read back, compare, upload) while
                                 * the frames change: the PRT panel itself is drawn at every frame */

/* A probe prepared on a worker thread (runtime_probe_prepare: its fine cube and, for a vMF file, its
 * prefiltered ladder, seconds) while the window keeps drawing with the light it has. Ownership: the
 * worker reads the file and the probe, which nothing writes while the viewer runs, and writes only
 * out, rc and err, then sets done (release); the UI thread reads them after seeing done (acquire) and
 * joining the thread, and only then lends out to the runtimes, so every runtime's state changes on
 * the UI thread alone. */
typedef struct view_prep {
    pthread_t thread;
    bool running;               /* UI thread: started and not joined yet */
    int probe;                  /* which probe */
    const prt_data *d;
    const prt_probe *p;
    int threads;
    runtime_probe out;          /* the worker's: its result, rc and err ... */
    int rc;
    prt_error err;
    atomic_bool done;           /* ... published by this */
} view_prep;

static const char *k_view = "view";

/* The keys' help, around the b key's line (keys_help: its runtimes from the table). */
static const char *k_keys =
    "  mouse left drag          orbit the camera around its target\n"
    "  mouse right/middle drag  pan\n"
    "  mouse wheel              zoom (dolly toward the target)\n"
    "  shift or ctrl + left drag  rotate the lighting (yaw, pitch): a light change\n"
    "  1 .. 9                   switch to probe 1..9\n"
    "  n / p                    next / previous probe\n"
    "  + / -                    exposure up / down half a stop\n"
    "  K / k                    use more / fewer BRDF terms\n"
    "  C / c                    use more / fewer wavelet coefficients per vector (doubles / halves; the largest first)\n"
    "  [ / ]                    rotate the lighting 15 degrees about +y (a light change)\n";
static const char *k_keys2 =
    "  v                        view model of the runtimes that have per pixel: per-pixel view maps / per vertex\n"
    "  d                        direct only vs with bounces (files precomputed with --keep-direct)\n"
    "  s                        screenshot (PNG, current exposure); with --truth the three panels and their figures\n"
    "  l                        pick the next local light (point / spot lights of the file and --light)\n"
    "  alt + left drag          move the picked local light in the view plane: a light move\n"
    "  m                        mouse mode: left drag moves the picked local light / orbits\n"
    "  o                        local lights' one bounce (two VSGLs per light) on / off, where the effects plan has it\n"
    "  i                        local lights' indirect highlights on / off, where the effects plan has them\n"
    "  r                        reset camera, light rotation and local lights\n"
    "  h or ?                   show / hide this help on screen\n"
    "  q or Esc                 quit\n";

/* The keys' help into buf (cap bytes): the b key switches between the runtimes of the window. */
static const char *keys_help(char *buf, size_t cap) {
    int n = snprintf(buf, cap, "%s  b                        switch to the next runtime:", k_keys);
    for (int i = 0, k = 0; i < runtime_backend_count() && n > 0 && (size_t)n < cap; i++) {
        const runtime_backend_info *b = runtime_backend_at(i);
        if (b->caps & RUNTIME_CAP_WINDOW) n += snprintf(buf + n, cap - (size_t)n, "%s the %s runtime", k++ ? "," : "", b->title);
    }
    if (n > 0 && (size_t)n < cap) snprintf(buf + n, cap - (size_t)n, "\n%s", k_keys2);
    return buf;
}

/* The runtime at start: the first of the window's that has the per-pixel view model, else its first. */
static int start_backend(void) {
    int first = -1;
    for (int i = 0; i < runtime_backend_count(); i++) {
        unsigned caps = runtime_backend_at(i)->caps;
        if ((caps & RUNTIME_CAP_WINDOW) && (caps & RUNTIME_CAP_VIEW_PIXEL)) return i;
        if ((caps & RUNTIME_CAP_WINDOW) && first < 0) first = i;
    }
    return first;
}

/* Prints the usage, options and keys. */
static void view_help(void) {
    char keys[4096];
    int start = start_backend();
    printf("usage: prt view FILE.prt --probe PROBE [--probe P2 ...] [--probes DIR] [options]\n"
           "\n"
           "Interactive relighting: a window showing the scene relit under the probe, with\n"
           "the frame rate and the last light-change and view-change times on screen.\n"
           "\n"
           "  --probe PROBE          a light probe (repeatable; keys 1-9 / n / p switch)\n"
           "  --probes DIR           every .exr, .hdr and .pfm probe in DIR\n"
           "  --layout L             probe layout: latlong, angular, vcross, hcross (default: auto)\n"
           "  --size WxH             window size (default 1024x768)\n"
           "  --camera EX,EY,EZ[,TX,TY,TZ[,FOV]]  initial camera (default: as prt render)\n"
           "  --camera-name NAME      the file's camera of that name (a glTF scene's; default: its first)\n"
           "  --light-rotation Y[,P] initial light rotation in degrees (yaw about +y, then pitch; default 0)\n"
           "  --exposure E           exposure in stops (default: from the first probe, as prt render)\n"
           "  --terms K              BRDF terms used (default: all)\n"
           "  --aa N                 antialiasing: N samples per pixel (multisampling; default %d, 1: off); the\n"
           "                         frames of a mouse drag take one sample, the still frame after it N\n", CLI_AA_DEFAULT);
    cli_backend_help(25, RUNTIME_CAP_WINDOW, start >= 0 ? runtime_backend_at(start)->name : "none");
    printf("                         (on a software GL renderer, such as Mesa's llvmpipe, the default is a\n"
           "                         backend that runs on the CPU: it is many times faster there)\n"
           "  --view-model pixel|vertex  view model of the runtimes that have per pixel (default pixel)\n"
           "  --threads T            CPU runtime threads (default: all cores)\n"
           "  --frames N             render N frames, then exit (no interaction; default: interactive)\n"
           "  --screenshot OUT.png   with --frames: save the last frame; otherwise the S key's file\n"
           "                         (default: the next free prt-view-NNN.png)\n"
           "  --window-shot OUT.png  with --frames: also save the window as displayed, text included\n"
           "  --keys CHARS           with --frames: press these keys, one before each frame from the second\n"
           "                         (default: none)\n"
           "  --light SPEC           add a local light: point:pos=x,y,z;intensity=W/sr;colour=r,g,b or\n"
           "                         spot:pos=..;dir=..;inner=DEG;outer=DEG;... (repeatable; GL takes at most 4)\n"
           "  --no-file-lights       ignore the lights stored in the file\n"
           "  --truth                split the window: PRT | a progressive path-traced reference (prt reference's,\n"
           "                         with the file's bounces) | their relative error, with the error on screen\n"
           "  --truth-spp N          with --frames: each frame waits until the reference has N samples per pixel,\n"
           "                         and it stops there (the same reference for every frame of one state)\n"
           CLI_INDIRECT_HELP
           "\n"
           "keys:\n%s", keys_help(keys, sizeof keys));
}

typedef struct viewer {
    const char *file;
    prt_data d;
    prt_probe probes[VIEW_MAX_PROBES];
    char names[VIEW_MAX_PROBES][128];
    int nprobes, probe;
    glctx *ctx;
    gltext text;
    prt_runtime *rts[VIEW_MAX_RUNTIMES];    /* by table position: the backends that draw into ctx (else NULL) */
    bool stale[VIEW_MAX_RUNTIMES];          /* that runtime has not seen the current light yet */
    int cur;                /* the runtime in use (key b) */
    prt_camera cam, cam0;
    float lyaw, lpitch, lyaw0, lpitch0, R[9];
    bool vertex_model, help, quit, direct;
    int kmax, kfile, nthreads;
    int aa;                 /* --aa: samples per pixel */
    float exposure;
    bool light_dirty, view_dirty, present_dirty;
    double lightvec_ms, light_ms, view_ms, frame_ms;
    const char *light_backend, *view_backend;
    char status[4300];
    double status_until, title_at;
    int fbw, fbh;
    int drag;               /* 0 none, 1 orbit, 2 pan, 3 light */
    double mx, my;
    const char *shot_path, *window_shot, *keys;
    bool window_shot_now;
    int shots;
    prt_lights lights, lights0;   /* local lights: current, and as loaded (key r) */
    int pick;                   /* the picked local light */
    bool move_mode;             /* key m: left drag moves the picked light */
    bool local_dirty, local_stale[VIEW_MAX_RUNTIMES];
    double local_ms, bounce_ms, indirect_ms;   /* the last light move, its one-bounce part; the indirect view part */
    const char *local_backend;
    bool bounce;                /* key o: the local lights' one bounce (VSGLs) */
    int hl_on, hl_samples;      /* key i: rays per glossy vertex when on (--highlight-samples or 32), now (0: off) */
    const char *no_bounce, *no_hl;   /* why the effects plan has no such effect (NULL: it has) */
    runtime_probe prepared[VIEW_MAX_PROBES];   /* probe i prepared (ready[i]), lent to the runtimes */
    bool ready[VIEW_MAX_PROBES];
    long used[VIEW_MAX_PROBES], uses;          /* when each was last shown, for keeping VIEW_KEEP */
    view_prep prep;
    int want;                   /* the probe asked for while it is prepared (-1: none) */
    double prep_t0, prep_ms;    /* when the preparation started, how long the last one took */
    int prep_frames;            /* frames drawn while a probe was prepared, and the longest */
    double prep_longest;
    /* --truth (view_truth.h): the PRT frame at panel size pw x ph beside the reference and the error */
    bool truth;
    int truth_spp;              /* --truth-spp: each scripted frame waits for it (0: none) */
    truth_view *tv;
    truth_state ts_last;        /* the state last handed to the reference (what a restart changed) */
    int pw, ph;
    float *prt_px, *ref_px, *err_e;    /* [3 pw ph], [3 pw ph], [pw ph] */
    uint8_t *cov, *rgba;        /* [pw ph], [4 pw ph] */
    bool prt_new;               /* the PRT frame changed since it was compared */
    long seen_samples, seen_restarts;
    truth_stats st;
    cmp_result cr;
    bool have_err;
    double refresh_at;          /* when the panels were last refreshed */
    double prt_ms;              /* the PRT frame's cost: its last T x L plus its last view change */
    GLuint tex[2], fbo[2];      /* the reference and error panels, uploaded */
    truth_point pts[VIEW_POINTS];
    int npts, cur_pt;
    truth_plot_range plot;      /* the plot's axes, for its labels */
    const char *snap_path;      /* a --truth snapshot to write at the next frame, before the swap */
    char snap_buf[4096];
    /* keys c / C: coefficients per vector used (0: all the file keeps, nfile at most) */
    int ncoef, nfile;
    prt_transport full[PRT_MAX_TRANSFERS][2];   /* the file's sets while cut ones are in d (transport, direct) */
    bool cut;
    bool remake[VIEW_MAX_RUNTIMES];   /* that runtime uploaded other sets: made again when next used */
    long truth_restarts;        /* scripted: the restarts and spp the last frame printed */
    int truth_spp_last;
    truth_stats st_before;      /* scripted: the reference as the frame found it, before any wait */
} viewer;

/* Shows msg on screen for a few seconds and on stderr. */
static void set_status(viewer *v, const char *msg) {
    snprintf(v->status, sizeof v->status, "%s", msg);
    v->status_until = prt_now() + 4.0;
    fprintf(stderr, "prt view: %s\n", msg);
    v->present_dirty = true;
}

/* Light rotation matrix through probe_parse_rotation, so the convention is exactly `prt render --light-rotation`. */
static void update_rotation(viewer *v) {
    char s[64];
    snprintf(s, sizeof s, "%.6f,%.6f", v->lyaw, v->lpitch);
    if (probe_parse_rotation(s, v->R) != 0) {
        static const float I[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
        memcpy(v->R, I, sizeof I);
    }
}

static bool rotated(const viewer *v) { return v->lyaw != 0 || v->lpitch != 0; }

/* The runtime in use (the b key switches), and its backend. */
static prt_runtime *current(const viewer *v) { return v->rts[v->cur]; }
static const runtime_backend_info *current_info(const viewer *v) { return runtime_backend_at(v->cur); }

/* Light change on the current runtime: the rotated probe through runtime_set_light (the other
 * runtime catches up when it is switched to). */
static int light_change(viewer *v, prt_error *err) {
    if (v->light_dirty) {
        for (int i = 0; i < VIEW_MAX_RUNTIMES; i++) v->stale[i] = true;
        v->light_dirty = false;
    }
    prt_runtime *rt = current(v);
    runtime_lend_probe(rt, v->ready[v->probe] ? &v->prepared[v->probe] : NULL);
    if (runtime_set_light(rt, &v->probes[v->probe], rotated(v) ? v->R : NULL, err)) return -1;
    runtime_timing t;
    runtime_get_timing(rt, &t);
    v->lightvec_ms = t.light_vector_ms;
    v->light_ms = t.light_ms;
    v->light_backend = current_info(v)->title;
    v->stale[v->cur] = false;
    return 0;
}

/* Local-light move on the current runtime (the other catches up when switched to). */
static int local_move(viewer *v, prt_error *err) {
    if (v->local_dirty) {
        for (int i = 0; i < VIEW_MAX_RUNTIMES; i++) v->local_stale[i] = true;
        v->local_dirty = false;
    }
    prt_runtime *rt = current(v);
    if (runtime_set_local_lights(rt, &v->lights, err)) return -1;
    runtime_timing t;
    runtime_get_timing(rt, &t);
    v->local_ms = t.local_ms;
    v->bounce_ms = t.bounce_ms;
    v->local_backend = current_info(v)->title;
    v->local_stale[v->cur] = false;
    return 0;
}

/* View change: relit frame of the current camera into the runtime's float target. */
static int view_change(viewer *v, prt_error *err) {
    double t0 = prt_now();
    prt_runtime *rt = current(v);
    render_desc rd = { .width = v->truth ? v->pw : v->fbw, .height = v->fbh, .camera = v->cam, .background = &v->probes[v->probe],
                       .background_rotation = rotated(v) ? v->R : NULL, .samples = v->drag ? 1 : v->aa };
    runtime_set_terms(rt, v->kmax);
    if (runtime_render(rt, &rd, NULL, err)) return -1;
    v->view_ms = 1e3 * (prt_now() - t0);
    runtime_timing t;
    runtime_get_timing(rt, &t);
    v->indirect_ms = t.indirect_view_ms;
    v->view_backend = current_info(v)->title;
    return 0;
}

/* The local-light effects' line of the overlay (keys o, i) into buf; its length. */
static int overlay_effects(const viewer *v, char *buf, size_t cap) {
    char b[96], h[96];
    if (v->no_bounce) snprintf(b, sizeof b, "none (%s)", v->no_bounce);
    else if (v->bounce) snprintf(b, sizeof b, "on, %.1f ms of the light move", v->bounce_ms);
    else snprintf(b, sizeof b, "off");
    if (v->no_hl) snprintf(h, sizeof h, "none (%s)", v->no_hl);
    else if (v->hl_samples) snprintf(h, sizeof h, "on (%d rays), %.1f ms of the view change", v->hl_samples, v->indirect_ms);
    else snprintf(h, sizeof h, "off");
    int n = snprintf(buf, cap, "o: one bounce %s   i: indirect highlights %s\n", b, h);
    return n < 0 ? 0 : n >= (int)cap ? (int)cap - 1 : n;
}

static int truth_hud(const viewer *v, char *buf, size_t cap);

/* Draws the status text (and the key help when toggled) over the window. */
static void overlay(viewer *v) {
    char buf[8192];
    runtime_timing t;
    runtime_get_timing(current(v), &t);
    bool pixel = current_info(v)->caps & RUNTIME_CAP_VIEW_PIXEL;   /* kernel and view model: where there is a choice */
    const char *slash = strrchr(v->file, '/');
    int n = snprintf(buf, sizeof buf,
                     "%s   %s runtime%s%s%s   [%.40s, %s]\n"
                     "probe %d/%d: %s   light yaw %.0f pitch %.0f   K %d of %d   exposure %+.1f   AA %dx%s\n"
                     "frame %.1f ms (%.0f fps)   light change %.1f ms = light vector %.1f + T x L %.1f %s   view change %.1f ms %s\n",
                     slash ? slash + 1 : v->file, current_info(v)->title, pixel ? " (light kernel " : "",
                     pixel ? t.kernel : "", pixel ? (v->vertex_model ? ", per-vertex view)" : ", per-pixel view)") : "",
                     v->ctx->renderer, glctx_kind_name(v->ctx->kind),
                     v->probe + 1, v->nprobes, v->names[v->probe], v->lyaw, v->lpitch, v->kmax ? v->kmax : v->kfile,
                     v->kfile, v->exposure, v->drag ? 1 : v->aa,
                     prt_data_transfer(&v->d)->direct.nvecs == 0 ? "" : v->direct ? "   direct only" : "   direct + bounces", v->frame_ms, v->frame_ms > 0 ? 1e3 / v->frame_ms : 0.0,
                     v->lightvec_ms + v->light_ms, v->lightvec_ms, v->light_ms, v->light_backend ? v->light_backend : "", v->view_ms,
                     v->view_backend ? v->view_backend : "");
    if (v->lights.count > 0 && n < (int)sizeof buf) {
        const prt_light *l = &v->lights.light[v->pick];
        n += snprintf(buf + n, sizeof buf - n, "local light %d/%d (%s) at %.2f %.2f %.2f   light move %.1f ms %s%s\n",
                      v->pick + 1, v->lights.count, l->type == PRT_LIGHT_SPOT ? "spot" : "point", l->pos[0], l->pos[1],
                      l->pos[2], v->local_ms, v->local_backend ? v->local_backend : "",
                      v->move_mode ? "   [m: drag moves the light]" : "");
        n += overlay_effects(v, buf + n, sizeof buf - (size_t)n);
    }
    if (v->truth && n < (int)sizeof buf) n += truth_hud(v, buf + n, sizeof buf - (size_t)n);
    if (prt_now() < v->status_until && n < (int)sizeof buf) n += snprintf(buf + n, sizeof buf - n, "%s\n", v->status);
    if (v->want >= 0 && n < (int)sizeof buf)
        n += snprintf(buf + n, sizeof buf - n, "preparing probe %d: %s... (%.1f s; showing probe %d meanwhile)\n", v->want + 1,
                      v->names[v->want], prt_now() - v->prep_t0, v->probe + 1);
    char keys[4096];
    if (n < (int)sizeof buf) snprintf(buf + n, sizeof buf - n, "%s", v->help ? keys_help(keys, sizeof keys) : "h: help");
    size_t len = strlen(buf);
    while (len && buf[len - 1] == '\n') buf[--len] = 0;
    int scale = v->fbh >= 1400 ? 2 : 1;
    gltext_draw(&v->text, v->fbw, v->fbh, 10, 10, scale, buf);
}

/* Saves the float target as an image file (exposure applied for 8-bit formats). */
static int screenshot(viewer *v, const char *path, prt_error *err) {
    prt_image img;
    if (runtime_read(current(v), &img, err)) return -1;
    image_desc d = { .exposure = v->exposure };
    int rc = image_write(path, &img, &d, err);
    image_free(&img);
    return rc;
}

/* Saves the window's back buffer as displayed (tone-mapped, text included): 8-bit sRGB codes,
 * decoded to linear so that image_write's sRGB encoding gives the same codes back. */
static int window_screenshot(viewer *v, const char *path, prt_error *err) {
    const gl_api *gl = &v->ctx->gl;
    int w = v->fbw, h = v->fbh;
    uint8_t *px = malloc((size_t)w * h * 4);
    prt_image img;
    if (!px || image_alloc(&img, w, h, 3, err)) { free(px); return prt_fail(err, "out of memory"); }
    gl->BindFramebuffer(GL_FRAMEBUFFER, 0);
    gl->ReadBuffer(GL_BACK);
    gl->PixelStorei(GL_PACK_ALIGNMENT, 1);
    gl->ReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, px);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++) {
                float s = px[4 * ((size_t)(h - 1 - y) * w + x) + c] / 255.0f;
                img.data[3 * ((size_t)y * w + x) + c] = s <= 0.04045f ? s / 12.92f : powf((s + 0.055f) / 1.055f, 2.4f);
            }
    free(px);
    image_desc d = { 0 };
    int rc = image_write(path, &img, &d, err);
    image_free(&img);
    return rc;
}

/* ---------------------------------------------------------------- --truth: PRT | reference | error */

/* What differs between two reference states, in words (static text). */
static const char *truth_change(const truth_state *a, const truth_state *b) {
    if (a->w != b->w || a->h != b->h) return "window size";
    if (memcmp(&a->cam, &b->cam, sizeof a->cam)) return "camera";
    if (a->probe != b->probe) return "probe";
    if (a->rotated != b->rotated || memcmp(a->R, b->R, sizeof a->R)) return "light rotation";
    return "local lights";
}

/* The panels' buffers for the framebuffer's size (three panels side by side). -1 with err. */
static int truth_panels(viewer *v, prt_error *err) {
    int pw = v->fbw / 3 > 0 ? v->fbw / 3 : 1, ph = v->fbh;
    if (pw == v->pw && ph == v->ph && v->prt_px) return 0;
    size_t n = (size_t)pw * ph;
    free(v->prt_px); free(v->ref_px); free(v->err_e); free(v->cov); free(v->rgba);
    v->prt_px = calloc(3 * n, sizeof(float));
    v->ref_px = calloc(3 * n, sizeof(float));
    v->err_e = calloc(n, sizeof(float));
    v->cov = calloc(n, 1);
    v->rgba = calloc(4 * n, 1);
    if (!v->prt_px || !v->ref_px || !v->err_e || !v->cov || !v->rgba) return prt_fail(err, "out of memory");
    v->pw = pw;
    v->ph = ph;
    v->view_dirty = true;
    return 0;
}

/* Hands the current camera, size, probe, rotation and local lights to the reference: a restart
 * when any differs from the last. */
static void truth_update(viewer *v) {
    truth_state s = { .cam = v->cam, .w = v->pw, .h = v->ph, .probe = &v->probes[v->probe], .rotated = rotated(v),
                      .lights = v->lights };
    memcpy(s.R, v->R, sizeof s.R);
    truth_set(v->tv, &s, v->ts_last.w ? truth_change(&v->ts_last, &s) : "start");
    v->ts_last = s;
}

/* The PRT frame read back (after a view change). -1 with err. */
static int truth_read_prt(viewer *v, prt_error *err) {
    prt_image img;
    if (runtime_read(current(v), &img, err)) return -1;
    int rc = img.w == v->pw && img.h == v->ph ? 0 : prt_fail(err, "the PRT frame is %dx%d, not %dx%d", img.w, img.h, v->pw, v->ph);
    if (!rc) memcpy(v->prt_px, img.data, 3 * sizeof(float) * (size_t)v->pw * v->ph);
    image_free(&img);
    return rc;
}

/* Coefficients per vector the runtimes use (keys c / C). */
static int coefficients_used(const viewer *v) { return v->ncoef ? v->ncoef : v->nfile; }

/* The settings the knobs give, in words (the plot's label, the snapshot's figures). */
static void truth_settings(const viewer *v, char *buf, size_t cap) {
    snprintf(buf, cap, "K %d, n %d, %s%s%s", v->kmax ? v->kmax : v->kfile, coefficients_used(v),
             v->direct ? "direct only" : "bounces", v->lights.count && v->bounce ? ", local bounce" : "",
             v->lights.count && v->hl_samples ? ", highlights" : "");
}

/* Records the current settings' frame time and error (the plot's point; the latest of each). */
static void truth_record(viewer *v) {
    char label[48];
    truth_settings(v, label, sizeof label);
    int i = 0;
    while (i < v->npts && strcmp(v->pts[i].label, label)) i++;
    if (i == v->npts && v->npts == VIEW_POINTS) i = VIEW_POINTS - 1;   /* full: the last is replaced */
    else if (i == v->npts) v->npts++;
    v->pts[i].ms = (float)v->prt_ms;
    v->pts[i].err = (float)v->cr.rel_rmse;
    snprintf(v->pts[i].label, sizeof v->pts[i].label, "%s", label);
    v->cur_pt = i;
}

/* Uploads rgba (pw x ph) as panel k's texture, attached to its framebuffer for the blit. */
static void truth_upload(viewer *v, int k, const uint8_t *rgba) {
    const gl_api *gl = &v->ctx->gl;
    if (!v->tex[k]) {
        gl->GenTextures(1, &v->tex[k]);
        gl->GenFramebuffers(1, &v->fbo[k]);
    }
    gl->BindTexture(GL_TEXTURE_2D, v->tex[k]);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    gl->PixelStorei(GL_UNPACK_ALIGNMENT, 1);
    gl->TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, v->pw, v->ph, 0, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
    gl->BindTexture(GL_TEXTURE_2D, 0);
    gl->BindFramebuffer(GL_FRAMEBUFFER, v->fbo[k]);
    gl->FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, v->tex[k], 0);
    gl->BindFramebuffer(GL_FRAMEBUFFER, 0);
}

/* The reference's estimate and the error against the PRT frame, into the two panels, when either
 * changed: at once after a restart or when exact (--truth-spp), else at most every VIEW_TRUTH_REFRESH. */
static void truth_refresh(viewer *v, bool exact) {
    truth_stats peek;
    truth_peek(v->tv, &peek);
    v->st.seconds = peek.seconds;
    if (!v->prt_new && peek.samples == v->seen_samples && peek.restarts == v->seen_restarts && v->tex[0]) return;
    if (!exact && v->tex[0] && peek.restarts == v->seen_restarts && prt_now() - v->refresh_at < VIEW_TRUTH_REFRESH) return;
    v->refresh_at = prt_now();
    prt_error err = { { 0 } };
    if (v->prt_new && truth_read_prt(v, &err)) set_status(v, err.msg);
    v->prt_new = false;
    truth_read(v->tv, v->ref_px, v->cov, &v->st);
    v->seen_samples = v->st.samples;
    v->seen_restarts = v->st.restarts;
    v->have_err = truth_compare(v->prt_px, v->ref_px, v->cov, v->pw, v->ph, &v->cr, v->err_e, &err) == 0;
    if (v->have_err && v->st.covered >= 1.0) truth_record(v);
    size_t n = (size_t)v->pw * v->ph;
    truth_tonemap(v->ref_px, n, v->exposure, v->rgba);
    truth_upload(v, 0, v->rgba);
    truth_error_rgba(v->err_e, v->pw, v->ph, v->rgba);
    truth_plot(v->rgba, v->pw, v->ph, v->pts, v->npts, v->cur_pt, &v->plot);
    truth_upload(v, 1, v->rgba);
}

/* The reference and error panels drawn right of the PRT one (texture rows top first: flipped). */
static void truth_blit(viewer *v) {
    const gl_api *gl = &v->ctx->gl;
    for (int k = 0; k < 2 && v->tex[k]; k++) {
        gl->BindFramebuffer(GL_READ_FRAMEBUFFER, v->fbo[k]);
        gl->BindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
        gl->BlitFramebuffer(0, 0, v->pw, v->ph, (k + 1) * v->pw, v->ph, (k + 2) * v->pw, 0, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    }
    gl->BindFramebuffer(GL_FRAMEBUFFER, 0);
}

/* The HUD's truth lines into buf: the error, the reference's noise, samples and time, the knobs. */
static int truth_hud(const viewer *v, char *buf, size_t cap) {
    char err[160], set[64];
    const truth_stats *st = &v->st;
    if (st->error[0]) snprintf(err, sizeof err, "the reference stopped: %.120s", st->error);
    else if (!v->have_err) snprintf(err, sizeof err, "no pixel of the reference yet");
    else snprintf(err, sizeof err, "PRT %.2f %% off (rel_rmse over %.0f %% of the pixels)%s", 100 * v->cr.rel_rmse,
                  100 * st->covered, st->noise >= 0 && v->cr.rel_rmse <= st->noise ? ": within the noise" : "");
    truth_settings(v, set, sizeof set);
    int n = snprintf(buf, cap,
                     "truth: %s in %.1f ms; the reference: %d spp, noise %s%.2f %%, %.1f s (restarts %ld, last: %s)\n"
                     "knobs: %s   (K/k terms, C/c coefficients, d bounces, o local bounce, i highlights)\n",
                     err, v->prt_ms, st->spp, st->noise < 0 ? "n/a " : "", st->noise < 0 ? 0.0 : 100 * st->noise,
                     st->seconds, st->restarts, st->why ? st->why : "-", set);
    return n < 0 ? 0 : n >= (int)cap ? (int)cap - 1 : n;
}

/* Panel titles, the scale bar's and the plot's labels. */
static void truth_labels(viewer *v) {
    char t[96];
    int y = v->ph - TRUTH_BAR_Y - 18, x2 = 2 * v->pw + 10, span = v->pw - 20;
    gltext_draw(&v->text, v->fbw, v->fbh, 10, v->ph - 18, 1, "PRT");
    snprintf(t, sizeof t, "reference (%d spp%s)", v->st.spp, v->st.covered < 1 ? ", refining" : "");
    gltext_draw(&v->text, v->fbw, v->fbh, v->pw + 10, v->ph - 18, 1, t);
    static const char *ticks[4] = { "0.1%", "1%", "10%", "100%" };
    for (int i = 0; i < 4; i++) gltext_draw(&v->text, v->fbw, v->fbh, x2 + i * span / 3 - (i == 3 ? 24 : 0), y, 1, ticks[i]);
    if (v->pw < TRUTH_PLOT_W + 20) return;   /* no room for the plot (truth_plot draws none) */
    snprintf(t, sizeof t, "error %.1f-%.1f %% vs", 100 * v->plot.err_min, 100 * v->plot.err_max);
    int px = 3 * v->pw - TRUTH_PLOT_W - 10, py = TRUTH_PLOT_Y(v->ph) + TRUTH_PLOT_H + 5;
    gltext_draw(&v->text, v->fbw, v->fbh, px, py, 1, t);
    snprintf(t, sizeof t, "0-%.0f ms: %d settings", v->plot.ms_max, v->npts);
    gltext_draw(&v->text, v->fbw, v->fbh, px, py + 16, 1, t);
}

/* path without its extension, then suffix, into out. */
static void sibling(const char *path, const char *suffix, char *out, size_t cap) {
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    int len = dot && (!slash || dot > slash) ? (int)(dot - path) : (int)strlen(path);
    snprintf(out, cap, "%.*s%s", len, path, suffix);
}

/* A --truth snapshot: the window as shown (the three panels and the HUD) at path, and beside it
 * PATH-prt.exr, PATH-ref.exr (zero where the reference has no sample) and PATH.txt (the figures). */
static int window_screenshot(viewer *v, const char *path, prt_error *err);
static int truth_snapshot(viewer *v, const char *path, prt_error *err) {
    char p[4200], set[64];
    size_t n = (size_t)v->pw * v->ph;
    prt_image img;
    if (window_screenshot(v, path, err) || image_alloc(&img, v->pw, v->ph, 3, err)) return -1;
    memcpy(img.data, v->prt_px, 3 * n * sizeof(float));
    sibling(path, "-prt.exr", p, sizeof p);
    int rc = image_write(p, &img, &(image_desc){ 0 }, err);
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) img.data[3 * i + c] = v->cov[i] ? v->ref_px[3 * i + c] : 0.0f;
    sibling(path, "-ref.exr", p, sizeof p);
    if (!rc) rc = image_write(p, &img, &(image_desc){ 0 }, err);
    image_free(&img);
    sibling(path, ".txt", p, sizeof p);
    FILE *f = rc ? NULL : fopen(p, "w");
    if (!rc && !f) return prt_fail(err, "%s: cannot write", p);
    if (rc) return -1;
    truth_settings(v, set, sizeof set);
    fprintf(f, "rel_rmse %.8f\nmax_rel_err %.8f\nnoise %.8f\nspp %d\ncovered %.6f\nprt_ms %.3f\nreference_s %.3f\n"
               "restarts %ld\nsettings %s\n",
            v->have_err ? v->cr.rel_rmse : -1, v->have_err ? v->cr.max_rel_err : -1, v->st.noise, v->st.spp, v->st.covered,
            v->prt_ms, v->st.seconds, v->st.restarts, set);
    return fclose(f) ? prt_fail(err, "%s: cannot write", p) : 0;
}

/* The truth side of a frame: the state handed over (scripted: waited for, the samples it had before
 * kept for truth_line), the panels refreshed. */
static void truth_frame(viewer *v, bool scripted) {
    truth_update(v);
    if (scripted) truth_peek(v->tv, &v->st_before);
    if (scripted && v->truth_spp > 0) truth_wait(v->tv, v->truth_spp, 600);
    truth_refresh(v, (scripted && v->truth_spp > 0) || v->snap_path);   /* a snapshot shows the frame it saves */
}

/* The current runtime made again from d's sets when it uploads them at creation (RUNTIME_CAP_GL) and
 * they changed since (remake; the cpu runtime reads them at every light change): seconds on a software
 * GL, so only the one in use, when it is used. It then catches up with the light and local lights. -1
 * with err when it cannot be made (the viewer goes on with the next runtime). */
static prt_runtime *make_runtime(viewer *v, int i, prt_error *err);
static int remake_current(viewer *v, prt_error *err) {
    int i = v->cur;
    if (!v->remake[i]) return 0;
    v->remake[i] = false;
    runtime_destroy(v->rts[i]);
    v->stale[i] = true;
    v->local_stale[i] = v->lights.count > 0;
    if ((v->rts[i] = make_runtime(v, i, err))) return 0;
    while (!v->rts[v->cur]) v->cur = (v->cur + 1) % VIEW_MAX_RUNTIMES;
    return -1;
}

/* Keys c / C: the first n coefficients per vector by importance (transport_keep_largest; 0: all the
 * file keeps) in every sparse set: the cpu runtime reads them at its next light change, a GL one is
 * made again when next used (remake_current). */
static void set_coefficients(viewer *v, int n, bool quiet) {
    prt_error err = { { 0 } };
    double t0 = prt_now();
    for (int i = 0; i < v->d.ntransfers && v->cut; i++)
        if (v->d.transfers[i].ops->kind == TRANSFER_LINEAR) {
            transport_free(&v->d.transfers[i].transport);
            transport_free(&v->d.transfers[i].direct);
            v->d.transfers[i].transport = v->full[i][0];
            v->d.transfers[i].direct = v->full[i][1];
        }
    v->cut = false;
    v->ncoef = 0;
    for (int i = 0; i < v->d.ntransfers && n > 0; i++) {
        prt_transfer *tr = &v->d.transfers[i];
        if (tr->ops->kind != TRANSFER_LINEAR) continue;
        prt_transport a = { 0 }, b = { 0 };
        if (transport_keep_largest(&tr->transport, n, &a, &err) ||
            (tr->direct.nvecs && transport_keep_largest(&tr->direct, n, &b, &err))) {
            transport_free(&a);
            set_status(v, err.msg);
            set_coefficients(v, 0, true);
            return;
        }
        v->full[i][0] = tr->transport;
        v->full[i][1] = tr->direct;
        tr->transport = a;
        if (tr->direct.nvecs) tr->direct = b;
        v->cut = true;
        v->ncoef = n;
    }
    v->light_dirty = true;
    if (quiet) return;
    for (int i = 0; i < VIEW_MAX_RUNTIMES; i++) v->remake[i] = v->rts[i] && (runtime_backend_at(i)->caps & RUNTIME_CAP_GL);
    char msg[160];
    snprintf(msg, sizeof msg, "%d of %d coefficients per vector, the largest first (cut in %.0f ms)", n ? n : v->nfile, v->nfile,
             1e3 * (prt_now() - t0));
    set_status(v, msg);
}

/* Key c (halves) and C (doubles) the coefficients per vector used, within 1 .. the file's N. */
static void step_coefficients(viewer *v, bool more) {
    int cur = v->ncoef ? v->ncoef : v->nfile;
    int n = more ? 2 * cur : cur / 2;
    if (n < 1 || (cur >= v->nfile && more)) { set_status(v, more ? "already using every coefficient the file keeps" : "already at 1 coefficient"); return; }
    set_coefficients(v, n >= v->nfile ? 0 : n, false);
}

/* One frame: light change if needed, view change if needed, present, text, swap. */
static int frame(viewer *v, bool force_view, prt_error *err) {
    double t0 = prt_now();
    int w, h;
    glfwGetFramebufferSize((GLFWwindow *)v->ctx->window, &w, &h);
    if (w < 1 || h < 1) return 0; /* minimized */
    if (w != v->fbw || h != v->fbh) { v->fbw = w; v->fbh = h; v->view_dirty = true; }
    if (v->truth && truth_panels(v, err)) return -1;
    prt_error rerr = { { 0 } };
    if (remake_current(v, &rerr)) set_status(v, rerr.msg);
    bool lit = v->light_dirty || v->stale[v->cur];
    if (lit && light_change(v, err)) return -1;
    if (v->local_dirty || v->local_stale[v->cur]) {
        if (local_move(v, err)) return -1;
        lit = true;
    }
    if (lit || v->view_dirty || force_view) {
        if (view_change(v, err)) return -1;
        v->frame_ms = 1e3 * (prt_now() - t0);
        v->prt_ms = v->light_ms + v->view_ms;   /* what the knobs change: T x L and the view change */
        v->prt_new = v->truth;
    }
    v->view_dirty = false;
    if (v->truth) truth_frame(v, force_view);
    runtime_present(current(v), v->truth ? v->pw : v->fbw, v->fbh, v->exposure);
    if (v->truth) truth_blit(v);
    overlay(v);
    if (v->truth) truth_labels(v);
    if (v->window_shot_now && window_screenshot(v, v->window_shot, err)) return -1;
    if (v->snap_path) {
        const char *p = v->snap_path;
        v->snap_path = NULL;
        if (truth_snapshot(v, p, err)) {   /* scripted: an error; interactive: said, the viewer goes on */
            if (force_view) return -1;
            char msg[1200];
            snprintf(msg, sizeof msg, "snapshot failed: %s", err->msg);
            set_status(v, msg);
        }
    }
    glfwSwapBuffers((GLFWwindow *)v->ctx->window);
    v->present_dirty = false;
    if (prt_now() - v->title_at > 0.5) {
        char title[256];
        snprintf(title, sizeof title, "prt view - %s - %.1f ms/frame", v->file, v->frame_ms);
        glfwSetWindowTitle((GLFWwindow *)v->ctx->window, title);
        v->title_at = prt_now();
    }
    return 0;
}

/* ---------------------------------------------------------------- input */

static void orbit(viewer *v, float dyaw, float dpitch) {
    float off[3];
    v3_sub(off, v->cam.eye, v->cam.target);
    float r = v3_len(off);
    if (r <= 0) return;
    float yaw = atan2f(off[0], off[2]), pitch = asinf(fmaxf(-1.0f, fminf(1.0f, off[1] / r)));
    yaw += dyaw;
    pitch += dpitch;
    const float lim = 89.0f * (float)M_PI / 180.0f;
    if (pitch > lim) pitch = lim;
    if (pitch < -lim) pitch = -lim;
    float d[3] = { cosf(pitch) * sinf(yaw), sinf(pitch), cosf(pitch) * cosf(yaw) };
    v3_madd(v->cam.eye, v->cam.target, d, r);
    v->view_dirty = true;
}

/* Moves eye and target in the view plane by a pixel offset. */
static void pan(viewer *v, float dx, float dy) {
    float f[3], r[3], u[3], off[3];
    camera_basis(&v->cam, f, r, u);
    v3_sub(off, v->cam.eye, v->cam.target);
    float fov = v->cam.fov_deg > 0 ? v->cam.fov_deg : 40;
    float k = 2.0f * v3_len(off) * tanf(fov * (float)M_PI / 360.0f) / (float)(v->fbh > 0 ? v->fbh : 1);
    for (int i = 0; i < 3; i++) {
        float m = (-dx * r[i] + dy * u[i]) * k;
        v->cam.eye[i] += m;
        v->cam.target[i] += m;
    }
    v->view_dirty = true;
}

/* Dollies the eye toward the target by 10% per wheel step, within sane limits. */
static void zoom(viewer *v, float steps) {
    float off[3];
    v3_sub(off, v->cam.eye, v->cam.target);
    float size = 0;
    for (int i = 0; i < 3; i++) size = fmaxf(size, v->d.scene.bmax[i] - v->d.scene.bmin[i]);
    float r = v3_len(off), nr = r * powf(0.9f, steps);
    if (nr < 1e-3f * size) nr = 1e-3f * size;
    if (nr > 100.0f * size + 1) nr = 100.0f * size + 1;
    if (r > 0) v3_madd(v->cam.eye, v->cam.target, off, nr / r);
    v->view_dirty = true;
}

/* Moves the picked local light in the view plane by a pixel offset (the scale of pan at the light's depth). */
static void move_light(viewer *v, float dx, float dy) {
    float f[3], r[3], u[3], off[3];
    prt_light *l = &v->lights.light[v->pick];
    camera_basis(&v->cam, f, r, u);
    v3_sub(off, l->pos, v->cam.eye);
    float depth = fmaxf(v3_dot(off, f), 1e-3f);
    float fov = v->cam.fov_deg > 0 ? v->cam.fov_deg : 40;
    float k = 2.0f * depth * tanf(fov * (float)M_PI / 360.0f) / (float)(v->fbh > 0 ? v->fbh : 1);
    for (int i = 0; i < 3; i++) l->pos[i] += (dx * r[i] - dy * u[i]) * k;
    v->local_dirty = true;
}

/* Key l: the next local light, named on screen. */
static void pick_light(viewer *v) {
    if (v->lights.count == 0) {
        set_status(v, "no local lights (add some with --light or a scene's \"lights\")");
        return;
    }
    v->pick = (v->pick + 1) % v->lights.count;
    char spec[300], msg[360];
    light_format(&v->lights.light[v->pick], spec, sizeof spec);
    snprintf(msg, sizeof msg, "local light %d: %s", v->pick + 1, spec);
    set_status(v, msg);
}

/* Starts a drag: left orbit, shift/ctrl-left light rotation, right/middle pan. */
static void on_mouse_button(GLFWwindow *w, int button, int action, int mods) {
    viewer *v = glfwGetWindowUserPointer(w);
    if (action == GLFW_RELEASE) {   /* a drag's frames take one sample per pixel: the still one takes --aa */
        v->view_dirty |= v->drag && v->aa > 1;
        v->drag = 0;
        return;
    }
    glfwGetCursorPos(w, &v->mx, &v->my);
    bool move = v->lights.count > 0 && ((mods & GLFW_MOD_ALT) || v->move_mode);
    if (button == GLFW_MOUSE_BUTTON_LEFT) v->drag = move ? 4 : (mods & (GLFW_MOD_SHIFT | GLFW_MOD_CONTROL)) ? 3 : 1;
    else if (button == GLFW_MOUSE_BUTTON_RIGHT || button == GLFW_MOUSE_BUTTON_MIDDLE) v->drag = 2;
}

/* Applies the current drag. */
static void on_cursor(GLFWwindow *w, double x, double y) {
    viewer *v = glfwGetWindowUserPointer(w);
    if (!v->drag) return;
    float dx = (float)(x - v->mx), dy = (float)(y - v->my);
    v->mx = x;
    v->my = y;
    /* Window to framebuffer pixels (HiDPI). */
    int ww, wh;
    glfwGetWindowSize(w, &ww, &wh);
    float sc = ww > 0 ? (float)v->fbw / (float)ww : 1;
    if (v->drag == 1) orbit(v, -dx * 0.008f, dy * 0.008f);
    else if (v->drag == 2) pan(v, dx * sc, dy * sc);
    else if (v->drag == 4) move_light(v, dx * sc, dy * sc);
    else {
        v->lyaw += dx * 0.4f;
        v->lpitch += dy * 0.4f;
        v->lyaw = fmodf(v->lyaw + 540.0f, 360.0f) - 180.0f;
        if (v->lpitch > 90) v->lpitch = 90;
        if (v->lpitch < -90) v->lpitch = -90;
        update_rotation(v);
        v->light_dirty = true;
    }
}

/* Wheel: zoom. */
static void on_scroll(GLFWwindow *w, double dx, double dy) {
    viewer *v = glfwGetWindowUserPointer(w);
    zoom(v, (float)dy);
}

/* The worker: prepares its probe, then publishes the result. */
static void *prep_main(void *arg) {
    view_prep *j = arg;
    j->rc = runtime_probe_prepare(j->d, j->p, j->threads, &j->out, &j->err);
    atomic_store_explicit(&j->done, true, memory_order_release);
    return NULL;
}

/* Starts preparing probe i on a worker thread with all cores but the one the frames need. */
static void prep_start(viewer *v, int i) {
    view_prep *j = &v->prep;
    memset(&j->out, 0, sizeof j->out);
    j->probe = i;
    j->d = &v->d;
    j->p = &v->probes[i];
    j->threads = prt_thread_count(v->nthreads) > 1 ? prt_thread_count(v->nthreads) - 1 : 1;
    j->rc = 0;
    atomic_store_explicit(&j->done, false, memory_order_relaxed);
    v->prep_t0 = prt_now();
    j->running = pthread_create(&j->thread, NULL, prep_main, j) == 0;
    if (!j->running) prep_main(j);   /* no thread: prepared here, taken in at the next poll */
}

/* Frees the prepared probes beyond VIEW_KEEP, the least recently shown first (never the one shown,
 * nor the one asked for: the runtimes hold only the probe shown, lent again at each light change). */
static void prep_keep(viewer *v) {
    for (;;) {
        int n = 0, old = -1;
        for (int i = 0; i < v->nprobes; i++)
            if (v->ready[i]) {
                n++;
                if (i != v->probe && i != v->want && (old < 0 || v->used[i] < v->used[old])) old = i;
            }
        if (n <= VIEW_KEEP || old < 0) return;
        for (int r = 0; r < VIEW_MAX_RUNTIMES; r++)
            if (v->rts[r]) runtime_lend_probe(v->rts[r], NULL);
        runtime_probe_free(&v->prepared[old]);
        v->ready[old] = false;
    }
}

/* Takes in the worker's probe when it is done (wait: blocks until it is), shows the probe asked for
 * once it is ready, and starts the next preparation it needs. */
static void prep_poll(viewer *v, bool wait) {
    view_prep *j = &v->prep;
    bool started = j->running || atomic_load_explicit(&j->done, memory_order_acquire);
    if (started && (wait || atomic_load_explicit(&j->done, memory_order_acquire))) {
        if (j->running) pthread_join(j->thread, NULL);
        j->running = false;
        atomic_store_explicit(&j->done, false, memory_order_relaxed);
        if (j->rc == 0) {
            v->prep_ms = j->out.ms;
            v->prepared[j->probe] = j->out;
            v->ready[j->probe] = true;
        } else {
            char msg[1200];
            snprintf(msg, sizeof msg, "cannot prepare probe %d: %s", j->probe + 1, j->err.msg);
            set_status(v, msg);
            if (v->want == j->probe) v->want = -1;
        }
    }
    if (v->want >= 0 && v->ready[v->want]) {
        v->probe = v->want;
        v->used[v->probe] = ++v->uses;
        v->want = -1;
        v->light_dirty = true;
        prep_keep(v);
    } else if (v->want >= 0 && !j->running) {
        prep_start(v, v->want);
        if (wait) prep_poll(v, true);
    }
}

/* Switches to probe i (a light change) or says there is no such probe. */
static void select_probe(viewer *v, int i) {
    char msg[160];
    if (i < 0 || i >= v->nprobes) {
        snprintf(msg, sizeof msg, "there %s only %d probe%s", v->nprobes == 1 ? "is" : "are", v->nprobes,
                 v->nprobes == 1 ? "" : "s");
        set_status(v, msg);
        return;
    }
    v->want = -1;
    if (i == v->probe) return;
    if (!v->ready[i]) {   /* drawn with the light it has until the worker is done (prep_poll) */
        v->want = i;
        if (!v->prep.running) prep_start(v, i);
        v->present_dirty = true;
        return;
    }
    v->probe = i;
    v->used[i] = ++v->uses;
    v->light_dirty = true;
}

/* S key: saves the float target as PNG (next free prt-view-NNN.png or --screenshot). */
static void take_screenshot(viewer *v) {
    char path[4096], msg[4200];
    if (v->shot_path) snprintf(path, sizeof path, "%s", v->shot_path);
    else {
        do snprintf(path, sizeof path, "prt-view-%03d.png", ++v->shots);
        while (access(path, F_OK) == 0 && v->shots < 999);
    }
    prt_error err = { { 0 } };
    if (v->truth) {   /* the window with its figures, at the next frame (before its swap) */
        snprintf(v->snap_buf, sizeof v->snap_buf, "%s", path);
        v->snap_path = v->snap_buf;
        v->present_dirty = true;
        snprintf(msg, sizeof msg, "saved %s and its -prt.exr, -ref.exr, .txt", path);
    } else if (screenshot(v, path, &err)) snprintf(msg, sizeof msg, "screenshot failed: %s", err.msg);
    else snprintf(msg, sizeof msg, "saved %s", path);
    set_status(v, msg);
}

/* D key: direct-only lighting vs direct + bounces, when the file keeps both (precompute --keep-direct). */
static void toggle_direct(viewer *v) {
    if (v->d.stats.bounces == 0) {
        set_status(v, "the file has no interreflection passes: it is direct lighting only");
        return;
    }
    if (prt_data_transfer(&v->d)->direct.nvecs == 0) {
        set_status(v, "the file keeps no direct-only transport (precompute with --keep-direct)");
        return;
    }
    prt_error err = { { 0 } };
    bool want = !v->direct;
    int i = 0;
    while (i < VIEW_MAX_RUNTIMES && (!v->rts[i] || runtime_use_direct(v->rts[i], want, &err) == 0)) i++;
    if (i < VIEW_MAX_RUNTIMES) {   /* the ones switched go back */
        while (i-- > 0)
            if (v->rts[i]) runtime_use_direct(v->rts[i], v->direct, NULL);
        char msg[1100];
        snprintf(msg, sizeof msg, "cannot switch the transport: %s", err.msg[0] ? err.msg : "no direct set");
        set_status(v, msg);
        return;
    }
    v->direct = want;
    v->light_dirty = true;
    char msg[128];
    snprintf(msg, sizeof msg, "%s", want ? "direct lighting only" : "direct lighting + interreflections");
    set_status(v, msg);
}

/* Keys o and i: the one bounce or the highlights on / off on every runtime (a light move each), where
 * the effects plan has them. */
static void toggle_effect(viewer *v, bool highlights) {
    const char *why = highlights ? v->no_hl : v->no_bounce;
    char msg[1200];
    if (v->lights.count == 0) why = "no local lights";
    if (why) {
        snprintf(msg, sizeof msg, "no %s: %s", highlights ? "indirect highlights" : "one bounce", why);
        set_status(v, msg);
        return;
    }
    bool bounce = highlights ? v->bounce : !v->bounce;
    int hl = highlights ? (v->hl_samples ? 0 : v->hl_on) : v->hl_samples;
    prt_error err = { { 0 } };
    int i = 0;
    while (i < VIEW_MAX_RUNTIMES && (!v->rts[i] || runtime_set_local_effects(v->rts[i], bounce, hl, &err) == 0)) i++;
    if (i < VIEW_MAX_RUNTIMES) {   /* the ones switched go back */
        while (i-- > 0)
            if (v->rts[i]) runtime_set_local_effects(v->rts[i], v->bounce, v->hl_samples, NULL);
        snprintf(msg, sizeof msg, "cannot switch: %s", err.msg);
        set_status(v, msg);
        return;
    }
    v->bounce = bounce;
    v->hl_samples = hl;
    for (i = 0; i < VIEW_MAX_RUNTIMES; i++) v->local_stale[i] = true;   /* each runtime's time of the move shows at its next frame */
    snprintf(msg, sizeof msg, "local lights: one bounce %s, indirect highlights %s", bounce ? "on" : "off", hl ? "on" : "off");
    set_status(v, msg);
}

/* Key b: the next runtime of the window (table order). */
static void next_runtime(viewer *v) {
    do v->cur = (v->cur + 1) % VIEW_MAX_RUNTIMES;
    while (!v->rts[v->cur]);
    v->view_dirty = true;
    char msg[128];
    snprintf(msg, sizeof msg, "%s runtime", current_info(v)->title);
    set_status(v, msg);
}

/* Key v: per-pixel view maps or per vertex, on every runtime that has per pixel. */
static void toggle_view_model(viewer *v) {
    v->vertex_model = !v->vertex_model;
    for (int i = 0; i < VIEW_MAX_RUNTIMES; i++)
        if (v->rts[i] && (runtime_backend_at(i)->caps & RUNTIME_CAP_VIEW_PIXEL))
            runtime_set_view(v->rts[i], v->vertex_model ? RUNTIME_VIEW_VERTEX : RUNTIME_VIEW_PIXEL, NULL);
    v->view_dirty = true;
    set_status(v, v->vertex_model ? "view model: per vertex" : "view model: per pixel (the runtimes that have it)");
}

/* Character keys (see k_keys). */
static void on_char(GLFWwindow *w, unsigned int c) {
    viewer *v = glfwGetWindowUserPointer(w);
    switch (c) {
    case '+': case '=': v->exposure += 0.5f; v->present_dirty = true; break;
    case '-': case '_': v->exposure -= 0.5f; v->present_dirty = true; break;
    case 'n': case 'N': select_probe(v, (v->probe + 1) % v->nprobes); break;
    case 'p': case 'P': select_probe(v, (v->probe + v->nprobes - 1) % v->nprobes); break;
    case 'K':
        if (v->kmax == 0 || v->kmax >= v->kfile) set_status(v, "already using every BRDF term the file has");
        else { v->kmax++; if (v->kmax == v->kfile) v->kmax = 0; v->view_dirty = true; }
        break;
    case 'k': {
        int cur = v->kmax ? v->kmax : v->kfile;
        if (cur <= 1) set_status(v, "already at 1 BRDF term");
        else { v->kmax = cur - 1; v->view_dirty = true; }
        break;
    }
    case 'c': step_coefficients(v, false); break;
    case 'C': step_coefficients(v, true); break;
    case '[': case ']':
        v->lyaw = fmodf(v->lyaw + (c == ']' ? 15.0f : -15.0f) + 540.0f, 360.0f) - 180.0f;
        update_rotation(v);
        v->light_dirty = true;
        break;
    case 'b': case 'B': next_runtime(v); break;
    case 'v': case 'V': toggle_view_model(v); break;
    case 'd': case 'D': toggle_direct(v); break;
    case 'l': case 'L': pick_light(v); break;
    case 'o': case 'O': toggle_effect(v, false); break;
    case 'i': case 'I': toggle_effect(v, true); break;
    case 'm': case 'M':
        v->move_mode = !v->move_mode;
        set_status(v, v->move_mode ? "left drag moves the picked local light" : "left drag orbits the camera");
        break;
    case 's': case 'S': take_screenshot(v); break;
    case 'r': case 'R':
        v->cam = v->cam0;
        v->lyaw = v->lyaw0;
        v->lpitch = v->lpitch0;
        update_rotation(v);
        v->light_dirty = v->view_dirty = true;
        v->local_dirty = v->lights.count > 0 || v->lights0.count > 0;
        v->lights = v->lights0;
        break;
    case 'h': case 'H': case '?': v->help = !v->help; v->present_dirty = true; break;
    case 'q': case 'Q': v->quit = true; break;
    default:
        if (c >= '1' && c <= '9') select_probe(v, (int)(c - '1'));
    }
}

/* Esc quits, F1 toggles help. */
static void on_key(GLFWwindow *w, int key, int scancode, int action, int mods) {
    viewer *v = glfwGetWindowUserPointer(w);
    if (action == GLFW_PRESS && key == GLFW_KEY_ESCAPE) v->quit = true;
    if (action == GLFW_PRESS && key == GLFW_KEY_F1) { v->help = !v->help; v->present_dirty = true; }
}

/* A resized framebuffer needs a new view change. */
static void on_resize(GLFWwindow *w, int width, int height) {
    viewer *v = glfwGetWindowUserPointer(w);
    v->view_dirty = true;
}

/* ---------------------------------------------------------------- setup */

static int add_probe(viewer *v, const char *path, const char *layout) {
    if (v->nprobes >= VIEW_MAX_PROBES) return cli_error(k_view, "at most %d probes", VIEW_MAX_PROBES);
    if (cli_load_probe(k_view, path, layout, &v->probes[v->nprobes])) return 1;
    const char *slash = strrchr(path, '/');
    snprintf(v->names[v->nprobes], sizeof v->names[0], "%s", slash ? slash + 1 : path);
    v->nprobes++;
    return 0;
}

static int cmp_str(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* Adds every .exr/.hdr/.pfm in dir, sorted by name; 1 after printing an error. */
static int add_probe_dir(viewer *v, const char *dir, const char *layout) {
    DIR *dp = opendir(dir);
    if (!dp) return cli_error(k_view, "%s: cannot open directory", dir);
    char *names[VIEW_MAX_PROBES];
    int n = 0;
    struct dirent *e;
    while ((e = readdir(dp)) && n < VIEW_MAX_PROBES) {
        char ext[16];
        prt_path_ext(e->d_name, ext);
        if (strcmp(ext, "exr") && strcmp(ext, "hdr") && strcmp(ext, "pfm")) continue;
        names[n] = malloc(strlen(dir) + strlen(e->d_name) + 2);
        if (!names[n]) break;
        sprintf(names[n], "%s/%s", dir, e->d_name);
        n++;
    }
    closedir(dp);
    qsort(names, n, sizeof names[0], cmp_str);
    int rc = n ? 0 : cli_error(k_view, "%s: no .exr, .hdr or .pfm probes in it", dir);
    for (int i = 0; i < n; i++) {
        if (!rc) rc = add_probe(v, names[i], layout);
        free(names[i]);
    }
    return rc;
}

/* Releases everything the viewer holds (not v itself). */
static void viewer_free(viewer *v) {
    if (v->prep.running) {   /* a preparation still running is waited for, then dropped */
        pthread_join(v->prep.thread, NULL);
        if (v->prep.rc == 0) runtime_probe_free(&v->prep.out);
    }
    truth_destroy(v->tv);
    if (v->cut) set_coefficients(v, 0, true);
    if (v->ctx) glctx_make_current(v->ctx, NULL);
    for (int k = 0; k < 2 && v->ctx; k++)
        if (v->tex[k]) { v->ctx->gl.DeleteFramebuffers(1, &v->fbo[k]); v->ctx->gl.DeleteTextures(1, &v->tex[k]); }
    free(v->prt_px); free(v->ref_px); free(v->err_e); free(v->cov); free(v->rgba);
    gltext_free(&v->text);
    for (int i = 0; i < VIEW_MAX_RUNTIMES; i++) runtime_destroy(v->rts[i]);
    for (int i = 0; i < VIEW_MAX_PROBES; i++) runtime_probe_free(&v->prepared[i]);
    glctx_destroy(v->ctx);
    for (int i = 0; i < v->nprobes; i++) probe_free(&v->probes[i]);
    prt_data_free(&v->d);
}

/* The command line beyond what goes straight into the viewer. */
typedef struct view_args {
    const char *layout, *cam_s, *cam_name, *rot_s, *dirs[16], *paths[VIEW_MAX_PROBES];
    int ndirs, npaths, w, h, frames;
    bool backend_given;         /* --backend: kept even on a software renderer */
    bool size_given;            /* --size (--truth's default is wider: three panels) */
    prt_lights extra;           /* --light */
    bool no_file_lights;
    cli_indirect indirect;      /* --local-bounce, --highlights and their --no- forms (-1: the file's) */
} view_args;

/* One option of argv at *i into v / a: 1 taken, 0 not an option of ours, -1 usage error (printed). */
static int parse_option(viewer *v, view_args *a, int argc, char **argv, int *i) {
    const char *val;
    int r;
#define OPT_S(name, var) if ((r = cli_opt(k_view, argc, argv, i, name, &(var)))) return r < 0 ? -1 : 1;
#define OPT_V(name) if ((r = cli_opt(k_view, argc, argv, i, name, &val)) < 0) return -1; else if (r)
    OPT_S("--layout", a->layout)
    OPT_S("--camera", a->cam_s)
    OPT_S("--camera-name", a->cam_name)
    OPT_S("--light-rotation", a->rot_s)
    OPT_S("--screenshot", v->shot_path)
    OPT_S("--window-shot", v->window_shot)
    OPT_S("--keys", v->keys)
    OPT_V("--probe") {
        if (a->npaths == VIEW_MAX_PROBES) return cli_error(k_view, "at most %d probes", VIEW_MAX_PROBES), -1;
        a->paths[a->npaths++] = val;
        return 1;
    }
    OPT_V("--probes") { if (a->ndirs < 16) a->dirs[a->ndirs++] = val; return 1; }
    OPT_V("--size") { a->size_given = true; return cli_size(k_view, val, &a->w, &a->h) ? 1 : -1; }
    OPT_V("--exposure") return cli_float(k_view, "--exposure", val, -64, 64, &v->exposure) ? 1 : -1;
    OPT_V("--terms") return cli_int(k_view, "--terms", val, 1, 64, &v->kmax) ? 1 : -1;
    OPT_V("--threads") return cli_int(k_view, "--threads", val, 1, 64, &v->nthreads) ? 1 : -1;
    OPT_V("--aa") return cli_int(k_view, "--aa", val, 1, CLI_AA_MAX, &v->aa) ? 1 : -1;
    OPT_V("--frames") return cli_int(k_view, "--frames", val, 1, 1000000, &a->frames) ? 1 : -1;
    OPT_V("--truth-spp") return cli_int(k_view, "--truth-spp", val, 1, 4096, &v->truth_spp) ? 1 : -1;
    if (!strcmp(argv[*i], "--truth")) { v->truth = true; return 1; }
    OPT_V("--backend") {
        if (!cli_backend(k_view, val, RUNTIME_CAP_WINDOW, "draw into a window")) return -1;
        v->cur = runtime_backend_index(val);
        a->backend_given = true;
        return 1;
    }
    OPT_V("--view-model") {
        if (strcmp(val, "pixel") && strcmp(val, "vertex"))
            return cli_error(k_view, "unknown --view-model '%s' (pixel or vertex)", val), -1;
        v->vertex_model = !strcmp(val, "vertex");
        return 1;
    }
#undef OPT_S
#undef OPT_V
    return 0;
}

/* The outputs (--screenshot, --window-shot) against each other and against every file the viewer
 * reads: the .prt, the --probe files and the probes in each --probes folder (as add_probe_dir picks
 * them). 0 or -1 (printed). */
static int check_files(const viewer *v, const view_args *a) {
    const cli_output outs[] = { { "--screenshot", v->shot_path, CLI_OUT_IMAGE }, { "--window-shot", v->window_shot, CLI_OUT_IMAGE } };
    cli_inputs ins = { 0 };
    cli_inputs_add(&ins, NULL, v->file);
    for (int i = 0; i < a->npaths; i++) cli_inputs_add(&ins, "--probe", a->paths[i]);
    for (int i = 0; i < a->ndirs; i++) {
        DIR *dp = opendir(a->dirs[i]);
        struct dirent *e;
        char path[8192], ext[16];
        while (dp && (e = readdir(dp))) {
            prt_path_ext(e->d_name, ext);
            if (strcmp(ext, "exr") && strcmp(ext, "hdr") && strcmp(ext, "pfm")) continue;
            snprintf(path, sizeof path, "%s/%s", a->dirs[i], e->d_name);
            cli_inputs_add(&ins, "--probes", path);
        }
        if (dp) closedir(dp);
    }
    return cli_check_files(k_view, outs, 2, &ins) ? -1 : 0;
}

/* Checks what the options say together (and the initial light rotation). 0 or -1 (printed). */
static int check_args(viewer *v, const view_args *a) {
    if (!v->file) return cli_error(k_view, "no input .prt file (see --help)"), -1;
    if ((v->window_shot || v->keys) && !a->frames) return cli_error(k_view, "--window-shot and --keys need --frames"), -1;
    if (v->truth_spp && (!v->truth || !a->frames)) return cli_error(k_view, "--truth-spp needs --truth and --frames"), -1;
    if (!a->npaths && !a->ndirs) return cli_error(k_view, "no light probe (--probe PROBE or --probes DIR)"), -1;
    if (cli_check_view_flags(k_view, a->layout, a->cam_s)) return -1;
    if (check_files(v, a)) return -1;
    if (a->rot_s) {
        float R[9];
        if (probe_parse_rotation(a->rot_s, R) != 0 || sscanf(a->rot_s, "%f", &v->lyaw) != 1)
            return cli_error(k_view, "bad --light-rotation '%s' (expected YAW or YAW,PITCH in degrees)", a->rot_s), -1;
        const char *comma = strchr(a->rot_s, ',');
        if (comma) v->lpitch = strtof(comma + 1, NULL);
    }
    return 0;
}

/* Parses argv into v and a: -1 to go on, else the exit status (0 after --help, 2 on usage errors). */
static int parse_args(int argc, char **argv, viewer *v, view_args *a) {
    memset(a, 0, sizeof *a);
    int lr = cli_take_lights(k_view, &argc, argv, &a->extra, &a->no_file_lights);
    if (lr) return lr;
    if ((lr = cli_take_indirect(k_view, &argc, argv, &a->indirect))) return lr;
    a->w = 1024;
    a->h = 768;
    v->exposure = NAN;   /* not given: from the first probe (cli_exposure) */
    v->aa = CLI_AA_DEFAULT;
    PRT_CHECK(runtime_backend_count() <= VIEW_MAX_RUNTIMES);
    v->cur = start_backend();
    if (v->cur < 0) return cli_error(k_view, "no backend of this build draws into a window"), 2;
    for (int i = 1; i < argc; i++) {
        if (cli_is_help(argv[i])) { view_help(); return 0; }
        int r = parse_option(v, a, argc, argv, &i);
        if (r < 0) return 2;
        if (r) continue;
        if (argv[i][0] == '-' && argv[i][1]) return cli_error(k_view, "unknown option '%s' (see --help)", argv[i]) + 1;
        if (v->file) return cli_error(k_view, "more than one input file ('%s' and '%s')", v->file, argv[i]) + 1;
        v->file = argv[i];
    }
    return check_args(v, a) ? 2 : -1;
}

/* The effects the file was made for (effects.h): what the o and i keys may turn on, and why not. */
static void view_effects_plan(viewer *v) {
    prt_effects fx;
    prt_file_effects(&v->d, &fx);
    v->no_bounce = fx.no_bounce;
    v->no_hl = fx.no_highlights;
}

/* The reference beside the PRT frame: the truth of the effects the file was made for, as `prt reference`
 * defaults to (the file's interreflection passes; the local lights' one bounce where its plan has an
 * indirect effect), whatever the knobs turn off in the PRT frame. -1 with err. */
static int truth_start(viewer *v, prt_error *err) {
    prt_effects fx;
    prt_file_effects(&v->d, &fx);
    int light_bounces = fx.local_bounce || fx.highlights ? 1 : 0;
    truth_desc td = { .bounces = v->d.stats.bounces, .light_depth = light_bounces + 1, .max_spp = v->truth_spp };
    v->tv = truth_create(&v->d.scene, &td, err);
    return v->tv ? 0 : -1;
}

/* Reads the file and the probes, frames the camera. Returns 0, or the exit status after printing. */
static int load_inputs(viewer *v, view_args *a) {
    prt_error err = { { 0 } };
    if (prtfile_read(v->file, &v->d, &err)) return cli_error(k_view, "%s", err.msg);
    int lr = cli_apply_lights(k_view, &v->d.scene, &a->extra, a->no_file_lights);
    if (lr) return lr;
    v->lights = v->lights0 = v->d.scene.lights;
    v->local_dirty = v->lights.count > 0;
    view_effects_plan(v);
    cli_indirect_resolve(&a->indirect, &v->d, false, &v->hl_samples, &v->bounce);
    if (v->truth && !a->size_given) { a->w = 1200; a->h = 450; }
    float aspect = v->truth ? (float)(a->w / 3) / a->h : (float)a->w / a->h;   /* --truth: a panel's */
    if (cli_camera(k_view, &v->d.scene, aspect, a->cam_s, a->cam_name, &v->cam)) return 2;
    v->cam0 = v->cam;
    for (int i = 0; i < a->npaths; i++)
        if (add_probe(v, a->paths[i], a->layout)) return 1;
    for (int i = 0; i < a->ndirs; i++)
        if (add_probe_dir(v, a->dirs[i], a->layout)) return 1;
    for (int m = 0; m < v->d.scene.nmaterials; m++)
        if (v->d.factors[m].K > v->kfile) v->kfile = v->d.factors[m].K;
    if (v->kmax >= v->kfile) v->kmax = 0;
    for (int i = 0; i < v->d.ntransfers; i++)
        if (v->d.transfers[i].ops->kind == TRANSFER_LINEAR && v->d.transfers[i].transport.N > v->nfile)
            v->nfile = v->d.transfers[i].transport.N;
    if (v->truth && truth_start(v, &err)) return cli_error(k_view, "%s", err.msg);
    v->lyaw0 = v->lyaw;
    v->lpitch0 = v->lpitch;
    update_rotation(v);
    v->want = -1;
    if (runtime_probe_prepare(&v->d, &v->probes[v->probe], v->nthreads, &v->prepared[v->probe], &err))
        return cli_error(k_view, "%s", err.msg);
    v->ready[v->probe] = true;
    v->exposure = cli_exposure(v->exposure, v->nprobes ? &v->probes[v->probe] : NULL, rotated(v) ? v->R : NULL, NULL);
    return 0;
}

/* On a software GL renderer the GL backend's per-pixel programs run at a few frames per second where
 * a backend that does its light and view changes on the CPU (no RUNTIME_CAP_GL) runs at tens: without
 * --backend the viewer starts on the first such window backend and says so. */
static void prefer_cpu_on_software(viewer *v, const view_args *a) {
    if (a->backend_given || !glctx_software(v->ctx) || !(current_info(v)->caps & RUNTIME_CAP_GL)) return;
    for (int i = 0; i < runtime_backend_count(); i++) {
        const runtime_backend_info *b = runtime_backend_at(i);
        if ((b->caps & RUNTIME_CAP_WINDOW) && !(b->caps & RUNTIME_CAP_GL)) {
            fprintf(stderr, "prt view: the GL renderer is software (%s): starting on the %s backend (b switches; "
                            "--backend %s starts there)\n", v->ctx->renderer, b->title, current_info(v)->name);
            v->cur = i;
            return;
        }
    }
}

/* The runtime of backend i (one that draws into a window) for the viewer's settings. NULL with err. */
static prt_runtime *make_runtime(viewer *v, int i, prt_error *err) {
    const runtime_backend_info *b = runtime_backend_at(i);
    runtime_desc desc = { .backend = b->name, .threads = v->nthreads, .ctx = v->ctx, .local_bounce = v->bounce,
                          .highlight_samples = v->hl_samples, .direct_only = v->direct };
    if (b->caps & RUNTIME_CAP_VIEW_PIXEL) desc.view = v->vertex_model ? RUNTIME_VIEW_VERTEX : RUNTIME_VIEW_PIXEL;
    return runtime_create(&v->d, &desc, err);
}

/* The window, both runtimes drawing into it, the text and the callbacks. 0 or 1 (error printed). */
static int open_window(viewer *v, const view_args *a) {
    prt_error err = { { 0 } };
    char title[512];
    snprintf(title, sizeof title, "prt view - %s", v->file);
    glctx_window_desc wd = { .width = a->w, .height = a->h, .title = title, .visible = true };
    v->ctx = glctx_create(GLCTX_GLFW, &wd, &err);
    if (!v->ctx) return cli_error(k_view, "%s", err.msg);
    v->hl_on = v->hl_samples ? v->hl_samples : 32;
    char kernels[512] = "";
    for (int i = 0, n = 0; i < runtime_backend_count(); i++) {
        const runtime_backend_info *b = runtime_backend_at(i);
        if (!(b->caps & RUNTIME_CAP_WINDOW)) continue;
        if (!(v->rts[i] = make_runtime(v, i, &err))) return cli_error(k_view, "%s", err.msg);
        runtime_timing tm;
        runtime_get_timing(v->rts[i], &tm);
        if (n >= 0 && n < (int)sizeof kernels) n += snprintf(kernels + n, sizeof kernels - n, "%s%s %s", n ? ", " : "", b->title, tm.kernel);
    }
    if (gltext_init(&v->text, &v->ctx->gl, &err)) return cli_error(k_view, "%s", err.msg);
    prefer_cpu_on_software(v, a);
    GLFWwindow *win = (GLFWwindow *)v->ctx->window;
    glfwSetWindowUserPointer(win, v);
    glfwSwapInterval(0); /* frame times are the renderer's, not the display's refresh */
    if (!a->frames) {
        glfwSetMouseButtonCallback(win, on_mouse_button);
        glfwSetCursorPosCallback(win, on_cursor);
        glfwSetScrollCallback(win, on_scroll);
        glfwSetCharCallback(win, on_char);
        glfwSetKeyCallback(win, on_key);
        glfwSetFramebufferSizeCallback(win, on_resize);
    }
    fprintf(stderr, "prt view: %s (%d vertices, %d vectors), GL %s on %s (%s), light kernels %s; press h for help\n",
            v->file, v->d.scene.mesh.nverts, prt_data_transfer(&v->d)->transport.nvecs, v->ctx->version, v->ctx->renderer,
            glctx_kind_name(v->ctx->kind), kernels);
    v->light_dirty = v->view_dirty = true;
    return 0;
}

/* A scripted frame's truth figures on stdout (a restart since the last frame first). */
static void truth_line(viewer *v, int f) {
    static const char *none = "-";
    if (f > 0 && v->st.restarts != v->truth_restarts)
        printf("truth: restart (%s): spp %d -> %d, then refined to %d\n", v->st.why ? v->st.why : none, v->truth_spp_last,
               v->st_before.spp, v->st.spp);
    printf("truth: frame %d: spp %d, covered %.4f, rel_rmse %.6f, noise %.6f, prt %.2f ms, reference %.2f s, n %d, K %d%s\n",
           f, v->st.spp, v->st.covered, v->have_err ? v->cr.rel_rmse : -1.0, v->st.noise, v->prt_ms, v->st.seconds,
           coefficients_used(v), v->kmax ? v->kmax : v->kfile, v->st.error[0] ? "   (the reference stopped)" : "");
    if (v->st.error[0]) printf("truth: %s\n", v->st.error);
    v->truth_restarts = v->st.restarts;
    v->truth_spp_last = v->st.spp;
}

/* --frames N: the first frame is a light change, the others view changes of the same view (keys from
 * --keys pressed one before each frame from the second). 0 or 1. */
static int run_scripted(viewer *v, int frames) {
    prt_error err = { { 0 } };
    GLFWwindow *win = (GLFWwindow *)v->ctx->window;
    double sum_view = 0;
    size_t nkeys = v->keys ? strlen(v->keys) : 0;
    double wall0 = prt_now();
    for (int f = 0; f < frames && !glfwWindowShouldClose(win) && !v->quit; f++) {
        glfwPollEvents();
        if (f > 0 && (size_t)(f - 1) < nkeys) on_char(win, (unsigned char)v->keys[f - 1]);
        prep_poll(v, f == frames - 1);   /* the last frame shows every key's probe */
        v->window_shot_now = v->window_shot && f == frames - 1;
        if (v->truth && v->shot_path && f == frames - 1) v->snap_path = v->shot_path;
        bool preparing = v->want >= 0;
        double t0 = prt_now();
        if (frame(v, true, &err)) return cli_error(k_view, "%s", err.msg);
        if (v->truth) truth_line(v, f);
        if (preparing) {
            v->prep_frames++;
            v->prep_longest = fmax(v->prep_longest, 1e3 * (prt_now() - t0));
        }
        if (f > 0 || frames == 1) sum_view += v->view_ms;
    }
    if (v->shot_path && !v->truth && screenshot(v, v->shot_path, &err)) return cli_error(k_view, "%s", err.msg);
    printf("view: %d frames at %dx%d, %s runtime: light change %.1f ms (light vector %.1f ms), view change %.2f ms "
           "mean%s%s\n",
           frames, v->fbw, v->fbh, current_info(v)->title, v->light_ms, v->lightvec_ms,
           sum_view / (frames > 1 ? frames - 1 : 1), v->shot_path ? ", saved " : "", v->shot_path ? v->shot_path : "");
    if (v->truth && frames > 1)   /* everything a frame did, the reference's panels included: the rate a user sees */
        printf("view: --truth: %.1f ms per frame in all (%.1f fps) over %d frames\n", 1e3 * (prt_now() - wall0) / frames,
               frames / (prt_now() - wall0), frames);
    if (v->prep_ms > 0)
        printf("view: probe prepared on a worker thread in %.1f ms; %d frames drawn meanwhile, the longest %.1f ms\n",
               v->prep_ms, v->prep_frames, v->prep_longest);
    return 0;
}

/* The event loop: waits for input when nothing changes, draws when something did. 0 or 1. */
static int run_interactive(viewer *v) {
    prt_error err = { { 0 } };
    GLFWwindow *win = (GLFWwindow *)v->ctx->window;
    while (!glfwWindowShouldClose(win) && !v->quit) {
        bool busy = v->light_dirty || v->view_dirty || v->drag;
        if (busy) glfwPollEvents();
        else glfwWaitEventsTimeout(v->want >= 0 || v->truth ? 0.05 : 0.25);   /* a probe being prepared, the reference: often */
        if (v->truth) v->present_dirty = true;   /* the reference refines: its panels and figures follow */
        prep_poll(v, false);
        if (v->want >= 0) v->present_dirty = true;   /* the overlay counts its seconds */
        bool status_visible = v->status[0] && prt_now() < v->status_until + 0.3;
        if (v->light_dirty || v->view_dirty || v->present_dirty || v->stale[v->cur] || status_visible)
            if (frame(v, false, &err)) return cli_error(k_view, "%s", err.msg);
    }
    return 0;
}

/* `prt view` (see view_help): 0, 1 on errors, 2 on usage errors. */
int cli_view(int argc, char **argv) {
    viewer *v = calloc(1, sizeof *v);
    if (!v) return cli_error(k_view, "out of memory");
    view_args a;
    int rc = parse_args(argc, argv, v, &a);
    if (rc >= 0) { free(v); return rc; }
    rc = load_inputs(v, &a);
    if (rc == 0) rc = open_window(v, &a);
    if (rc == 0) rc = a.frames ? run_scripted(v, a.frames) : run_interactive(v);
    viewer_free(v);
    free(v);
    return rc;
}
