/* test_scene.c - scene loading (OBJ and JSON), materials, floor, demo.
 *
 * Truths: vertex counts of the procedural shapes (closed-form), the OBJ we
 * write ourselves, the floor's placement rule from scene.h computed here
 * independently from the models' bounds, and hand-transformed positions. */
#include "harness.h"
#include "scene.h"
#include "vec3.h"
#include <stdlib.h>
#include <string.h>

/* check.h's CHECK(cond) without a message expands to fprintf(stderr, ""). */
#pragma GCC diagnostic ignored "-Wformat-zero-length"

static void write_file(const char *path, const char *text) {
    FILE *f = fopen(path, "wb");
    if (!f) { perror(path); exit(2); }
    fputs(text, f);
    fclose(f);
}

static const char *tmp_path(const char *name) {
    static char buf[8][512];
    static int k;
    char *p = buf[k++ % 8];
    snprintf(p, 512, "%s/%s", check_tmpdir(), name);
    return p;
}

/* A unit cube [0,1]^3 as 8 vertices and 6 quads (12 triangles), outward CCW. */
static const char *k_cube =
    "# unit cube\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

/* Checks the floor's placement against scene.h's rule, from the models' own bounds. */
static void check_floor(const prt_scene *s, int expect_n, float size) {
    CHECK(s->floor_first_vertex > 0, "floor present");
    if (s->floor_first_vertex <= 0) return;
    prt_mesh models = s->mesh;
    models.nverts = s->floor_first_vertex;
    float mn[3], mx[3], d[3];
    mesh_bounds(&models, mn, mx);
    v3_sub(d, mx, mn);
    int nf = s->mesh.nverts - s->floor_first_vertex;
    CHECK(nf == expect_n * expect_n, "floor vertices %d, expected %d", nf, expect_n * expect_n);
    float ext = d[0] > d[2] ? d[0] : d[2];
    float fmin[3] = { 1e30f, 1e30f, 1e30f }, fmax[3] = { -1e30f, -1e30f, -1e30f };
    int not_up = 0;
    for (int v = s->floor_first_vertex; v < s->mesh.nverts; v++) {
        for (int k = 0; k < 3; k++) {
            float x = s->mesh.pos[3 * v + k];
            fmin[k] = x < fmin[k] ? x : fmin[k];
            fmax[k] = x > fmax[k] ? x : fmax[k];
        }
        if (s->mesh.nrm[3 * v + 1] != 1.f) not_up++;
    }
    CHECK(not_up == 0);
    CHECK(fmax[1] == fmin[1] && fmin[1] < mn[1], "flat, below the lowest point (%g < %g)", fmin[1], mn[1]);
    CHECK_NEAR(mn[1] - fmin[1], 1e-3 * v3_len(d), 1e-6 * v3_len(d) + 1e-7, "lowered by 0.1%% of the scene diagonal");
    CHECK_NEAR(fmax[0] - fmin[0], size * ext, 1e-5 * size * ext);
    CHECK_NEAR(fmax[2] - fmin[2], size * ext, 1e-5 * size * ext);
    CHECK_NEAR(fmin[0] + fmax[0], mn[0] + mx[0], 1e-5 * size * ext, "centred in x");
    CHECK_NEAR(fmin[2] + fmax[2], mn[2] + mx[2], 1e-5 * size * ext, "centred in z");
    /* Scene bounds include the floor. */
    CHECK(s->bmin[1] == fmin[1] && s->bmin[0] <= fmin[0] && s->bmax[2] >= fmax[2]);
}

static void obj_scene(void) {
    const char *obj = tmp_path("cube.obj");
    write_file(obj, k_cube);
    prt_scene s;
    prt_error err = { "" };
    /* Alone: default material, no floor. */
    CHECK(scene_load(obj, NULL, &s, &err) == 0, "%s", err.msg);
    CHECK(s.mesh.nverts == 8 && s.mesh.ntris == 12 && s.nmaterials == 1 && s.floor_first_vertex == -1);
    CHECK(strcmp(s.material_spec[0], "lambert:kd=0.8") == 0, "%s", s.material_spec[0]);
    CHECK(s.load_stats.obj_vertices == 8 && s.load_stats.faces == 6);
    CHECK(s.bmin[0] == 0.f && s.bmax[1] == 1.f);
    scene_free(&s);

    /* With a material and a floor of about 31,000 vertices: 176 x 176 = 30,976. */
    scene_desc d = { .material = "phong:kd=0.6,0.05,0.05;ks=0.4;n=50", .floor = 1, .floor_verts = 31000 };
    CHECK(scene_load(obj, &d, &s, &err) == 0, "%s", err.msg);
    CHECK(s.nmaterials == 2 && strcmp(s.material_spec[0], d.material) == 0 &&
          strcmp(s.material_spec[1], "lambert:kd=0.7") == 0);
    CHECK(s.floor_first_vertex == 8);
    check_floor(&s, 176, 3.f);
    int wrong = 0;
    for (int v = 0; v < s.mesh.nverts; v++) wrong += s.mesh.mat[v] != (v < 8 ? 0 : 1);
    CHECK(wrong == 0, "per-vertex materials");
    scene_free(&s);

    /* Default floor count (floor_verts 0) and a floor material. */
    d = (scene_desc){ .floor = 1, .floor_material = "lambert:kd=0.3" };
    CHECK(scene_load(obj, &d, &s, &err) == 0, "%s", err.msg);
    CHECK(s.mesh.nverts - s.floor_first_vertex == 176 * 176 && strcmp(s.material_spec[1], "lambert:kd=0.3") == 0);
    /* A second floor is refused; a floor on an empty scene too. */
    CHECK(scene_add_floor(&s, 100, 3.f, NULL, &err) == -1 && strstr(err.msg, "already"), "%s", err.msg);
    scene_free(&s);
    d.floor = -1; /* "as the JSON says": an OBJ has none */
    CHECK(scene_load(obj, &d, &s, &err) == 0 && s.floor_first_vertex == -1);
    scene_free(&s);
}

static void floor_api(void) {
    prt_error err = { "" };
    prt_scene s;
    prt_mesh m;
    const float c[3] = { 2.f, 1.f, -1.f };
    CHECK(mesh_make_sphere(&m, c, 0.5f, 8, 16, &err) == 0);
    CHECK(scene_from_mesh(&m, NULL, &s, &err) == 0, "%s", err.msg);
    CHECK(m.pos == NULL && m.nverts == 0, "ownership taken");
    CHECK(s.mesh.nverts == 2 + 7 * 16 && s.nmaterials == 1);
    CHECK(scene_add_floor(&s, 0, 3.f, NULL, &err) == -1 && strstr(err.msg, "vertex count"), "%s", err.msg);
    CHECK(scene_add_floor(&s, -5, 3.f, NULL, &err) == -1);
    CHECK(scene_add_floor(&s, 100, -1.f, NULL, &err) == -1 && strstr(err.msg, "size"), "%s", err.msg);
    CHECK(s.floor_first_vertex == -1 && s.mesh.nverts == 2 + 7 * 16, "failed calls change nothing");
    CHECK(scene_add_floor(&s, 100, 2.f, NULL, &err) == 0, "%s", err.msg);
    check_floor(&s, 10, 2.f);
    CHECK_NEAR(s.bmax[0] - s.bmin[0], 2.0, 1e-5, "2 x sphere diameter");
    scene_free(&s);
    prt_scene e;
    memset(&e, 0, sizeof e);
    e.floor_first_vertex = -1;
    CHECK(scene_add_floor(&e, 100, 3.f, NULL, &err) == -1 && strstr(err.msg, "no models"), "%s", err.msg);
    scene_free(&e);
}

static void materials(void) {
    prt_scene s;
    memset(&s, 0, sizeof s);
    s.floor_first_vertex = -1;
    prt_error err = { "" };
    int a = scene_material(&s, "lambert:kd=0.5", &err);
    int b = scene_material(&s, "phong:kd=0.5;ks=0.3;n=20", &err);
    int c = scene_material(&s, "lambert:kd=0.5", &err);
    CHECK(a == 0 && b == 1 && c == 0 && s.nmaterials == 2, "%d %d %d", a, b, c);
    CHECK(s.materials[0].type == BRDF_LAMBERT && s.materials[1].type == BRDF_PHONG);
    CHECK_NEAR(s.materials[1].n, 20.0, 0);   /* exact: parsed from "20" */
    /* The same material spelled differently is shared (canonical form). */
    int d = scene_material(&s, "lambert:kd=0.5,0.5,0.5", &err);
    CHECK(d == 0, "%d: %s", d, err.msg);
    CHECK(scene_material(&s, "nosuchmodel:kd=1", &err) == -1 && err.msg[0], "%s", err.msg);
    CHECK(s.nmaterials == 2);
    char spec[300];
    memset(spec, 'x', sizeof spec - 1);
    spec[sizeof spec - 1] = 0;
    CHECK(scene_material(&s, spec, &err) == -1 && strstr(err.msg, "too long"), "%s", err.msg);
    /* At most PRT_MAX_MATERIALS distinct materials. */
    int ok = 1;
    for (int i = s.nmaterials; i < PRT_MAX_MATERIALS; i++) {
        snprintf(spec, sizeof spec, "lambert:kd=0.%03d", 100 + i);
        if (scene_material(&s, spec, &err) != i) { ok = 0; fprintf(stderr, "%s\n", err.msg); }
    }
    CHECK(ok && s.nmaterials == PRT_MAX_MATERIALS);
    CHECK(scene_material(&s, "lambert:kd=0.999", &err) == -1 && strstr(err.msg, "too many"), "%s", err.msg);
    CHECK(scene_material(&s, "lambert:kd=0.5", &err) == 0, "an existing one is still found");
    scene_free(&s);
}

static void json_scene(void) {
    /* The OBJ sits in a subfolder beside the JSON: paths are relative to the JSON. */
    char dir[600];
    snprintf(dir, sizeof dir, "%s/models", check_tmpdir());
    char cmd[700];
    snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
    CHECK(system(cmd) == 0);
    write_file(tmp_path("models/cube.obj"), k_cube);
    const char *json = tmp_path("scene.json");
    write_file(json,
               "{ \"models\": [\n"
               "    { \"obj\": \"models/cube.obj\", \"material\": \"phong:kd=0.6,0.05,0.05;ks=0.4;n=50\",\n"
               "      \"scale\": 2, \"translate\": [1, 0, 0], \"rotate_y\": 90 },\n"
               "    { \"sphere\": {\"center\": [0, 3, 0], \"radius\": 0.5, \"rings\": 6, \"segments\": 8},\n"
               "      \"material\": \"phong:kd=0.6,0.05,0.05;ks=0.4;n=50\" },\n"
               "    { \"box\": {\"min\": [-3, 0, -1], \"max\": [-2, 1, 0], \"open_top\": true, \"n\": 2},\n"
               "      \"material\": \"ggx:kd=0.2;ks=0.04;alpha=0.3\" },\n"
               "    { \"torus\": {\"center\": [0, 0.25, 3], \"major\": 0.5, \"minor\": 0.25, \"nu\": 12, \"nv\": 6} },\n"
               "    { \"plane\": {\"x\": [4, 5], \"z\": [0, 1], \"height\": 0.5, \"nx\": 3, \"nz\": 4},\n"
               "      \"material\": \"lambert:kd=0.8\", \"name\": \"shelf\" }\n"
               "  ],\n"
               "  \"floor\": { \"vertices\": 400, \"material\": \"lambert:kd=0.5\", \"size\": 2 } }\n");
    prt_scene s;
    prt_error err = { "" };
    CHECK(scene_load(json, NULL, &s, &err) == 0, "%s", err.msg);
    int nsph = 2 + 5 * 8, nbox = 5 * 9, ntor = 12 * 6, npl = 12;
    int nmodels = 8 + nsph + nbox + ntor + npl;
    CHECK(s.floor_first_vertex == nmodels, "%d vs %d", s.floor_first_vertex, nmodels);
    CHECK(s.mesh.nverts == nmodels + 400);
    CHECK(s.mesh.ntris == 12 + 2 * 8 * 5 + 5 * 8 + 2 * 72 + 2 * 6 + 2 * 19 * 19);
    /* Materials: cube and sphere share one; the torus takes the default (lambert:kd=0.8),
     * which the plane names too; then the box's and the floor's. */
    CHECK(s.nmaterials == 4, "%d materials", s.nmaterials);
    int want[5] = { 0, 0, 1, 2, 2 }, first[5] = { 0, 8, 8 + nsph, 8 + nsph + nbox, 8 + nsph + nbox + ntor };
    for (int k = 0; k < 5; k++) CHECK(s.mesh.mat[first[k]] == want[k], "model %d material %d", k, s.mesh.mat[first[k]]);
    CHECK(s.mesh.mat[nmodels] == 3 && strcmp(s.material_spec[3], "lambert:kd=0.5") == 0);
    CHECK(s.load_stats.obj_vertices == 8 && s.load_stats.faces == 6);
    /* The cube: p' = 2 Ry(90) p + (1,0,0): Ry(90) maps (x,y,z) to (z, y, -x). So the
     * cube's corner (1,1,1) goes to (2+1, 2, -2). Find it among the first 8. */
    int found = 0;
    for (int v = 0; v < 8; v++) {
        const float *p = s.mesh.pos + 3 * v;
        if (fabsf(p[0] - 3.f) < 1e-5f && fabsf(p[1] - 2.f) < 1e-5f && fabsf(p[2] + 2.f) < 1e-5f) found++;
    }
    CHECK(found == 1, "transformed corner");
    check_floor(&s, 20, 2.f);
    scene_free(&s);

    /* desc overrides: no floor; or a floor with another count and material. */
    scene_desc d = { .floor = 0 };
    CHECK(scene_load(json, &d, &s, &err) == 0 && s.floor_first_vertex == -1 && s.mesh.nverts == nmodels);
    CHECK(s.nmaterials == 3, "no floor material without a floor");
    scene_free(&s);
    d = (scene_desc){ .floor = -1, .floor_verts = 900, .floor_material = "lambert:kd=0.25" };
    CHECK(scene_load(json, &d, &s, &err) == 0, "%s", err.msg);
    check_floor(&s, 30, 2.f);
    CHECK(strcmp(s.material_spec[s.mesh.mat[s.mesh.nverts - 1]], "lambert:kd=0.25") == 0);
    scene_free(&s);

    /* "floor": true takes the defaults; a desc material fills models that name none. */
    const char *j2 = tmp_path("s2.json");
    write_file(j2, "{\"models\":[{\"sphere\":{}}],\"floor\":true}");
    d = (scene_desc){ .floor = -1, .material = "blinn:kd=0.3;ks=0.2;n=30" };
    CHECK(scene_load(j2, &d, &s, &err) == 0, "%s", err.msg);
    CHECK(s.floor_first_vertex == 2 + 31 * 64 && strcmp(s.material_spec[0], d.material) == 0);
    check_floor(&s, 176, 3.f);
    scene_free(&s);
}

static void expect_fail(const char *label, const char *name, const char *text, const char *needle) {
    const char *path = tmp_path(name);
    if (text) write_file(path, text);
    prt_scene s;
    prt_error err = { "" };
    int rc = scene_load(path, NULL, &s, &err);
    CHECK(rc == -1, "%s: rc %d", label, rc);
    CHECK(strstr(err.msg, path) != NULL, "%s: '%s' names the file", label, err.msg);
    CHECK(!needle || strstr(err.msg, needle), "%s: '%s' lacks '%s'", label, err.msg, needle);
    CHECK(s.mesh.nverts == 0 && s.mesh.pos == NULL && s.nmaterials == 0, "%s: nothing left allocated", label);
    printf("  %-24s -> %s\n", label, err.msg);
    scene_free(&s);
}

static void json_errors(void) {
    write_file(tmp_path("bad.obj"), "v 0 0 0\nbogus\n");
    expect_fail("missing scene", "nothere.json", NULL, "cannot open");
    expect_fail("unknown extension", "scene.txt", "hi", "unknown scene format");
    expect_fail("empty", "empty.json", "", "empty");
    expect_fail("syntax error", "syntax.json", "{ \"models\": [\n  { \"sphere\": {} },\n  { \"sphere\": { \"radius\": 1,, } }\n] }", ":3:");
    expect_fail("truncated", "trunc.json", "{ \"models\": [ { \"sphere\": {} }", "JSON syntax error");
    expect_fail("not an object", "array.json", "[1, 2]", "top level");
    expect_fail("no models", "nomodels.json", "{ \"floor\": true }", "models");
    expect_fail("empty models", "emptymodels.json", "{ \"models\": [] }", "non-empty array");
    expect_fail("missing OBJ", "missingobj.json", "{ \"models\": [ { \"obj\": \"nothere.obj\" } ] }", "nothere.obj: cannot open");
    expect_fail("bad OBJ", "badobj.json", "{ \"models\": [ { \"obj\": \"bad.obj\" } ] }", "bad.obj:2: unknown statement");
    expect_fail("unknown shape", "cyl.json", "{ \"models\": [ { \"cylinder\": {\"radius\": 1} } ] }", "unknown key 'cylinder'");
    /* "lights" is a key (test_locallight.c checks its contents): the unknown top key is another */
    expect_fail("unknown top key", "top.json", "{ \"models\": [ { \"sphere\": {} } ], \"cameras\": 3 }", "unknown key 'cameras'");
    expect_fail("lights not an array", "top2.json", "{ \"models\": [ { \"sphere\": {} } ], \"lights\": 3 }",
                "lights: expected an array of lights");
    expect_fail("unknown shape key", "skey.json", "{ \"models\": [ { \"sphere\": {\"radious\": 1} } ] }", "models[0].sphere: unknown key 'radious'");
    expect_fail("no shape", "noshape.json", "{ \"models\": [ { \"material\": \"lambert:kd=0.5\" } ] }", "no shape");
    expect_fail("two shapes", "two.json", "{ \"models\": [ { \"sphere\": {}, \"box\": {} } ] }", "one shape per model");
    expect_fail("wrong type", "type.json", "{ \"models\": [ { \"sphere\": {\"radius\": \"big\"} } ] }", "models[0].sphere.radius: expected a number");
    expect_fail("bad vector", "vec.json", "{ \"models\": [ { \"sphere\": {\"center\": [0, 1]} } ] }", "center: expected an array of 3 numbers");
    expect_fail("bad radius", "rad.json", "{ \"models\": [ { \"sphere\": {\"radius\": -1} } ] }", "radius");
    expect_fail("bad rings", "rings.json", "{ \"models\": [ { \"sphere\": {\"rings\": 2.5} } ] }", "rings: expected an integer");
    expect_fail("bad scale", "scale.json", "{ \"models\": [ { \"sphere\": {}, \"scale\": 0 } ] }", "scale: expected a positive number");
    expect_fail("bad material", "mat.json", "{ \"models\": [ { \"sphere\": {}, \"material\": \"nosuch:kd=1\" } ] }", "models[0].material");
    expect_fail("material type", "mat2.json", "{ \"models\": [ { \"sphere\": {}, \"material\": 5 } ] }", "material: expected a BRDF spec");
    expect_fail("inverted box", "box.json", "{ \"models\": [ { \"box\": {\"min\": [1,1,1], \"max\": [0,0,0]} } ] }", "models[0].box: box:");
    expect_fail("floor zero verts", "fl0.json", "{ \"models\": [ { \"sphere\": {} } ], \"floor\": {\"vertices\": 0} }", "floor.vertices");
    expect_fail("floor bad key", "fl1.json", "{ \"models\": [ { \"sphere\": {} } ], \"floor\": {\"verts\": 10} }", "unknown key 'verts'");
    expect_fail("floor bad type", "fl2.json", "{ \"models\": [ { \"sphere\": {} } ], \"floor\": 3 }", "floor: expected an object or true/false");
    expect_fail("light_prior type", "lp1.json", "{ \"models\": [ { \"sphere\": {} } ], \"light_prior\": 3 }", "light_prior: expected a probe path");
    expect_fail("light_prior empty", "lp2.json", "{ \"models\": [ { \"sphere\": {} } ], \"light_prior\": [] }", "light_prior: expected");
    expect_fail("light_prior comma", "lp3.json", "{ \"models\": [ { \"sphere\": {} } ], \"light_prior\": \"a.exr,b.exr\" }", "light_prior");
    expect_fail("light_prior item", "lp4.json", "{ \"models\": [ { \"sphere\": {} } ], \"light_prior\": [\"a.exr\", 2] }", "light_prior");
    expect_fail("refine type", "rf1.json", "{ \"models\": [ { \"sphere\": {} } ], \"refine\": 3 }", "refine: expected true/false or an object");
    expect_fail("refine threshold", "rf2.json", "{ \"models\": [ { \"sphere\": {} } ], \"refine\": { \"threshold\": 1.5 } }",
                "refine.threshold: expected a share");
    expect_fail("refine budget", "rf3.json", "{ \"models\": [ { \"sphere\": {} } ], \"refine\": { \"budget\": 2.5 } }",
                "refine.budget: expected an integer");
    expect_fail("refine key", "rf4.json", "{ \"models\": [ { \"sphere\": {} } ], \"refine\": { \"levels\": 2 } }",
                "unknown key 'levels'");
    expect_fail("refine models", "rf5.json", "{ \"models\": [ { \"sphere\": {} } ], \"refine\": { \"models\": 1 } }",
                "refine.models: expected true or false");
}

/* "light_prior" (scene.h): one path or an array, each relative to the JSON's folder (absolute kept),
 * comma-joined for precompute; none leaves it empty. */
static void light_prior_key(void) {
    static const struct { const char *text, *want; } k[] = {
        { "{ \"models\": [ { \"sphere\": {} } ], \"light_prior\": \"city.exr\" }", "/city.exr" },
        { "{ \"models\": [ { \"sphere\": {} } ], \"light_prior\": [\"p/a.exr\", \"/abs/b.exr\"] }", "/p/a.exr,/abs/b.exr" },
        { "{ \"models\": [ { \"sphere\": {} } ] }", "" },
    };
    for (int i = 0; i < 3; i++) {
        const char *path = tmp_path("lp-good.json");
        write_file(path, k[i].text);
        prt_scene s;
        prt_error err = { "" };
        CHECK(scene_load(path, NULL, &s, &err) == 0, "%s", err.msg);
        char want[4096];
        const char *slash = strrchr(path, '/');
        snprintf(want, sizeof want, "%.*s%s", k[i].want[0] ? (int)(slash - path) : 0, path, k[i].want);   /* the folder, then */
        CHECK(strcmp(s.light_prior, want) == 0, "light_prior '%s', want '%s'", s.light_prior, want);
        scene_free(&s);
    }
}

/* "refine" (scene.h): true/false, or an object whose fields default to zero (refine.h's defaults). */
static void refine_key(void) {
    static const struct { const char *text; bool on; float thr; int budget; bool models; } k[] = {
        { "{ \"models\": [ { \"sphere\": {} } ], \"refine\": true }", true, 0, 0, false },
        { "{ \"models\": [ { \"sphere\": {} } ], \"refine\": false }", false, 0, 0, false },
        { "{ \"models\": [ { \"sphere\": {} } ] }", false, 0, 0, false },
        { "{ \"models\": [ { \"sphere\": {} } ], \"refine\": { \"threshold\": 0.02, \"budget\": 9000, \"models\": true } }", true,
          0.02f, 9000, true },
        { "{ \"models\": [ { \"sphere\": {} } ], \"refine\": {} }", true, 0, 0, false },
    };
    for (int i = 0; i < (int)(sizeof k / sizeof k[0]); i++) {
        const char *path = tmp_path("rf-good.json");
        write_file(path, k[i].text);
        prt_scene s;
        prt_error err = { "" };
        CHECK(scene_load(path, NULL, &s, &err) == 0, "%s", err.msg);
        CHECK(s.refine.on == k[i].on && s.refine.threshold == k[i].thr && s.refine.budget == k[i].budget &&
                  s.refine.models == k[i].models,
              "case %d: on %d threshold %g budget %d models %d", i, s.refine.on, (double)s.refine.threshold, s.refine.budget,
              s.refine.models);
        scene_free(&s);
    }
}

static void demo(void) {
    prt_scene s;
    prt_error err = { "" };
    CHECK(scene_make_demo(&s, 0, &err) == -1 && err.msg[0]);
    CHECK(scene_make_demo(&s, 10000, &err) == 0, "%s", err.msg);
    int nf = s.mesh.nverts - s.floor_first_vertex;
    CHECK(nf == 100 * 100, "floor %d", nf); /* round(sqrt(10000)) = 100 */
    CHECK(s.floor_first_vertex > 4000 && s.floor_first_vertex < 8000, "models %d vertices", s.floor_first_vertex);
    CHECK(s.nmaterials == 5);
    /* what the demo is for: Lambert surfaces, a glossy Phong and a chrome one (a Phong lobe is about
     * 1/sqrt(n) rad wide: under 2 degrees at n >= 1000) */
    int types = 0, chrome = 0, glossy = 0;
    for (int i = 0; i < s.nmaterials; i++) {
        types |= 1 << s.materials[i].type;
        if (s.materials[i].type == BRDF_PHONG) {
            if (s.materials[i].n >= 1000) chrome++;
            else glossy++;
        }
    }
    CHECK((types & (1 << BRDF_LAMBERT)) && chrome == 1 && glossy == 1, "types %#x, chrome %d, glossy %d", types, chrome, glossy);
    CHECK(s.refine.on && s.refine.budget > s.mesh.nverts, "refined to %d (from %d)", s.refine.budget, s.mesh.nverts);
    check_floor(&s, 100, 5.f);
    /* A sun 45 degrees up casts shadows as long as an object is tall, in any
     * azimuth: every model point's shadow (its footprint pushed out by its
     * height) must land on the floor. */
    float fmin = s.bmin[0], fmax = s.bmax[0], zmin = s.bmin[2], zmax = s.bmax[2], fy = s.bmin[1];
    int off = 0, finite = 1;
    for (int v = 0; v < s.floor_first_vertex; v++) {
        const float *p = s.mesh.pos + 3 * v;
        float h = p[1] - fy;
        if (p[0] - h < fmin || p[0] + h > fmax || p[2] - h < zmin || p[2] + h > zmax) off++;
    }
    for (int i = 0; i < 3 * s.mesh.nverts; i++) finite &= isfinite(s.mesh.pos[i]) && isfinite(s.mesh.nrm[i]);
    CHECK(off == 0 && finite, "%d shadow points off the floor", off);
    /* Each object rests on y = 0 (its lowest vertex), just above the floor, and no
     * two objects come closer than 2 cm (none intersects another). */
    float lowest[PRT_MAX_MATERIALS];
    for (int i = 0; i < PRT_MAX_MATERIALS; i++) lowest[i] = 1e30f;
    for (int v = 0; v < s.floor_first_vertex; v++)
        if (s.mesh.pos[3 * v + 1] < lowest[s.mesh.mat[v]]) lowest[s.mesh.mat[v]] = s.mesh.pos[3 * v + 1];
    int floor_mat = s.mesh.mat[s.floor_first_vertex];
    for (int i = 0; i < s.nmaterials; i++)
        if (i != floor_mat) CHECK_NEAR(lowest[i], 0.0, 1e-5, "object %d rests on y = 0", i);
    CHECK(fy < 0.f && fy > -0.01f, "floor just below: %g", fy);
    float closest = 1e30f;
    for (int a = 0; a < s.floor_first_vertex; a++)
        for (int b = a + 1; b < s.floor_first_vertex; b++) {
            if (s.mesh.mat[a] == s.mesh.mat[b]) continue;
            float d[3];
            v3_sub(d, s.mesh.pos + 3 * a, s.mesh.pos + 3 * b);
            float l = v3_dot(d, d);
            if (l < closest) closest = l;
        }
    CHECK(sqrtf(closest) > 0.02f, "closest vertices of two objects %g apart", sqrtf(closest));
    printf("  demo: %d model vertices + %d floor, %d triangles, %d materials\n", s.floor_first_vertex, nf, s.mesh.ntris,
           s.nmaterials);
    scene_free(&s);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(obj_scene);
    CHECK_CASE(floor_api);
    CHECK_CASE(materials);
    CHECK_CASE(json_scene);
    CHECK_CASE(json_errors);
    CHECK_CASE(light_prior_key);
    CHECK_CASE(refine_key);
    CHECK_CASE(demo);
    return check_summary();
}
