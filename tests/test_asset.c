/* test_asset.c - glTF 2.0, PLY and OBJ + MTL models through assimp (src/scene/asset.h).
 *
 * Every file is written by the test itself (a quad, two coloured triangles, a point light, a
 * camera), and each loaded value is checked against the number the format's rule gives
 * (asset.h): glTF metallic-roughness onto GGX, MTL onto Phong, candela / 683 into W/sr, node
 * transforms, yfov. Bad files fail with one line naming the file. When Debian's
 * assimp-testmodels is installed, its BoxTextured variants must load to one mesh. */
#include "harness.h"
#include "asset.h"
#include "image.h"
#include "brdf.h"
#include "lights.h"
#include "scene.h"
#include "vec3.h"
#include <float.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define TESTMODELS "/usr/share/assimp/models/glTF2"

/* ---------------------------------------------------------------- a tiny glTF writer */

typedef struct gbuf {
    unsigned char bin[16384];
    size_t n;
    char views[4096], accs[4096];
    int nview;
} gbuf;

/* Appends data as a buffer view and an accessor (ctype: 5126 float, 5125 uint32) and returns the accessor's index. */
static int gb_add(gbuf *g, const void *data, size_t bytes, int ctype, int count, const char *type) {
    size_t at = g->n;
    memcpy(g->bin + at, data, bytes);
    g->n += (bytes + 3) & ~(size_t)3;
    size_t lv = strlen(g->views), la = strlen(g->accs);
    snprintf(g->views + lv, sizeof g->views - lv, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}", g->nview ? "," : "", at, bytes);
    snprintf(g->accs + la, sizeof g->accs - la, "%s{\"bufferView\":%d,\"componentType\":%d,\"count\":%d,\"type\":\"%s\"}",
             g->nview ? "," : "", g->nview, ctype, count, type);
    return g->nview++;
}

static void base64(const unsigned char *in, size_t n, char *out) {
    static const char k[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)in[i] << 16 | (i + 1 < n ? (uint32_t)in[i + 1] << 8 : 0) | (i + 2 < n ? in[i + 2] : 0);
        out[o++] = k[v >> 18 & 63];
        out[o++] = k[v >> 12 & 63];
        out[o++] = i + 1 < n ? k[v >> 6 & 63] : '=';
        out[o++] = i + 2 < n ? k[v & 63] : '=';
    }
    out[o] = 0;
}

/* Writes a glTF (glb: binary) of g's data and the rest of the document (rest: JSON members after
 * the buffers, without braces). uri: the buffer's external file (written beside), or NULL (embedded). */
static void write_gltf(const char *path, const gbuf *g, const char *rest, bool glb, const char *uri) {
    static char json[65536], b64[32768];
    char buf[300];
    if (glb) snprintf(buf, sizeof buf, "{\"byteLength\":%zu}", g->n);
    else if (uri) snprintf(buf, sizeof buf, "{\"byteLength\":%zu,\"uri\":\"%s\"}", g->n, uri);
    else base64(g->bin, g->n, b64);
    int n = snprintf(json, sizeof json, "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[%s%s%s],\"bufferViews\":[%s],"
                     "\"accessors\":[%s],%s}", glb || uri ? buf : "{\"byteLength\":", glb || uri ? "" : "", "", g->views, g->accs, rest);
    if (!glb && !uri) {   /* the embedded buffer: a data URI */
        static char tmp[65536];
        snprintf(tmp, sizeof tmp, "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":%zu,\"uri\":\"data:application/"
                 "octet-stream;base64,%s\"}],\"bufferViews\":[%s],\"accessors\":[%s],%s}", g->n, b64, g->views, g->accs, rest);
        n = snprintf(json, sizeof json, "%s", tmp);
    }
    FILE *f = fopen(path, "wb");
    if (!glb) {
        fwrite(json, 1, (size_t)n, f);
    } else {
        while (n % 4) json[n++] = ' ';
        uint32_t h[5] = { 0x46546C67u, 2, (uint32_t)(12 + 8 + n + 8 + g->n), (uint32_t)n, 0x4E4F534Au };
        fwrite(h, 4, 5, f);
        fwrite(json, 1, (size_t)n, f);
        uint32_t c[2] = { (uint32_t)g->n, 0x004E4942u };
        fwrite(c, 4, 2, f);
        fwrite(g->bin, 1, g->n, f);
    }
    fclose(f);
    if (uri) {
        char bp[600];
        snprintf(bp, sizeof bp, "%s/%s", check_tmpdir(), uri);
        FILE *b = fopen(bp, "wb");
        fwrite(g->bin, 1, g->n, b);
        fclose(b);
    }
}

static const float k_quad[12] = { 0, 0, 0, 1, 0, 0, 1, 0, 1, 0, 0, 1 };   /* y = 0, x and z in [0, 1] */
static const uint32_t k_quad_idx[6] = { 0, 3, 2, 0, 2, 1 };             /* counter-clockwise seen from +y */

/* The quad (node translated to y = 1) with a red metallic-roughness material, a point light of
 * 1366 cd (2 W/sr) at (1,3,0) under a parent node moved by x = 1, a spot light, a directional one
 * and a camera at (0,2,5) looking 30 degrees down with yfov 0.8. */
static void quad_scene(gbuf *g, char *rest, size_t cap) {
    memset(g, 0, sizeof *g);
    int p = gb_add(g, k_quad, sizeof k_quad, 5126, 4, "VEC3");
    int ix = gb_add(g, k_quad_idx, sizeof k_quad_idx, 5125, 6, "SCALAR");
    snprintf(rest, cap,
        "\"extensionsUsed\":[\"KHR_lights_punctual\",\"KHR_materials_clearcoat\"],"
        "\"materials\":[{\"name\":\"red\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.2,0.1,1],\"metallicFactor\":0.25,"
        "\"roughnessFactor\":0.5},\"extensions\":{\"KHR_materials_clearcoat\":{\"clearcoatFactor\":1}}}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":%d},\"indices\":%d,\"material\":0}]}],"
        "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.8,\"aspectRatio\":1.5,\"znear\":0.1}}],"
        "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"point\",\"color\":[1,0.5,0.25],\"intensity\":1366},"
        "{\"type\":\"spot\",\"intensity\":683,\"spot\":{\"innerConeAngle\":0.3,\"outerConeAngle\":0.6}},{\"type\":\"directional\"}]}},"
        "\"nodes\":[{\"mesh\":0,\"translation\":[0,1,0]},{\"name\":\"cam\",\"camera\":0,\"translation\":[0,2,5],"
        "\"rotation\":[-0.258819045,0,0,0.965925826]},{\"name\":\"parent\",\"translation\":[1,0,0],\"children\":[3]},"
        "{\"name\":\"bulb\",\"translation\":[0,3,0],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}},"
        "{\"name\":\"spot\",\"translation\":[0,4,0],\"rotation\":[-0.707106781,0,0,0.707106781],"
        "\"extensions\":{\"KHR_lights_punctual\":{\"light\":1}}},{\"name\":\"sun\",\"extensions\":{\"KHR_lights_punctual\":{\"light\":2}}}],"
        "\"scenes\":[{\"nodes\":[0,1,2,4,5]}],\"scene\":0", p, ix);
}

static const char *tmp_path(const char *name) {
    static char buf[8][600];
    static int k;
    char *b = buf[k++ % 8];
    snprintf(b, 600, "%s/%s", check_tmpdir(), name);
    return b;
}

static void write_text(const char *path, const char *text) {
    FILE *f = fopen(path, "wb");
    fputs(text, f);
    fclose(f);
}

/* Loads path alone into a fresh scene s and am. */
static int load(const char *path, const asset_desc *ad, prt_scene *s, asset_model *am, prt_error *err) {
    memset(s, 0, sizeof *s);
    s->floor_first_vertex = -1;
    return asset_load(path, ad, s, am, err);
}

/* ---------------------------------------------------------------- cases */

/* The quad's mesh in world space and its material by the metallic-roughness rule, with its source. */
static void gltf_metallic_roughness(void) {
    gbuf g;
    char rest[8192];
    quad_scene(&g, rest, sizeof rest);
    const char *path = tmp_path("quad.gltf");
    write_gltf(path, &g, rest, false, NULL);
    prt_scene s;
    asset_model am;
    prt_error err;
    CHECK(load(path, NULL, &s, &am, &err) == 0, "%s", err.msg);
    CHECK(am.mesh.nverts == 4 && am.mesh.ntris == 2, "%d vertices, %d triangles", am.mesh.nverts, am.mesh.ntris);
    for (int v = 0; v < am.mesh.nverts; v++) {
        /* the node's translation: exact (1 + 0 in float) */
        CHECK(am.mesh.pos[3 * v + 1] == 1.f, "vertex %d at y %g", v, am.mesh.pos[3 * v + 1]);
        /* glTF's flat normal of a counter-clockwise quad: +y (one cross product and a normalization) */
        CHECK_NEAR(am.mesh.nrm[3 * v + 1], 1, 4 * FLT_EPSILON);
    }
    CHECK(s.nmaterials == 1 && am.mesh.mat[0] == 0, "%d materials", s.nmaterials);
    const brdf_params *p = &s.materials[0];
    CHECK(p->type == BRDF_GGX);
    const float base[3] = { 0.8f, 0.2f, 0.1f }, metal = 0.25f;
    for (int c = 0; c < 3; c++) {
        /* the same float expressions as asset.c, printed with 9 digits and parsed back: exact, up to 1 ulp */
        CHECK_NEAR(p->kd[c], base[c] * (1 - metal), 2 * FLT_EPSILON * base[c]);
        CHECK_NEAR(p->ks[c], 0.04f * (1 - metal) + base[c] * metal, 2 * FLT_EPSILON);
    }
    CHECK_NEAR(p->alpha, 0.25, 2 * FLT_EPSILON, "alpha = roughness^2");
    CHECK(strstr(s.material_from[0], "quad.gltf material 'red' (glTF metallic-roughness") != NULL, "%s", s.material_from[0]);
    CHECK(strstr(s.notes, "KHR_materials_clearcoat ignored") != NULL, "notes: %s", s.notes);
    CHECK(strstr(s.notes, "light 'sun' skipped") != NULL, "notes: %s", s.notes);
    asset_model_free(&am);
    /* --material (or a JSON material) wins over the file's */
    asset_desc ad = { .material = "lambert:kd=0.5", .material_from = "--material" };
    CHECK(load(path, &ad, &s, &am, &err) == 0, "%s", err.msg);
    CHECK(s.nmaterials == 1 && s.materials[0].type == BRDF_LAMBERT && !strcmp(s.material_from[0], "--material"));
    asset_model_free(&am);
}

/* The same document as .gltf with an external .bin, embedded, and .glb: one mesh, bit for bit. */
static void gltf_variants_agree(void) {
    gbuf g;
    char rest[8192];
    quad_scene(&g, rest, sizeof rest);
    const char *paths[3] = { tmp_path("v_ext.gltf"), tmp_path("v_emb.gltf"), tmp_path("v.glb") };
    write_gltf(paths[0], &g, rest, false, "v_ext.bin");
    write_gltf(paths[1], &g, rest, false, NULL);
    write_gltf(paths[2], &g, rest, true, NULL);
    prt_scene s[3];
    asset_model am[3];
    prt_error err;
    for (int i = 0; i < 3; i++) CHECK(load(paths[i], NULL, &s[i], &am[i], &err) == 0, "%s", err.msg);
    for (int i = 1; i < 3; i++) {
        /* the same bytes through the same code: identical */
        CHECK(am[i].mesh.nverts == am[0].mesh.nverts && am[i].mesh.ntris == am[0].mesh.ntris);
        if (am[i].mesh.nverts != am[0].mesh.nverts || am[i].mesh.ntris != am[0].mesh.ntris) continue;
        CHECK(!memcmp(am[i].mesh.pos, am[0].mesh.pos, 12 * (size_t)am[0].mesh.nverts), "variant %d positions", i);
        CHECK(!memcmp(am[i].mesh.tris, am[0].mesh.tris, 12 * (size_t)am[0].mesh.ntris), "variant %d triangles", i);
        CHECK(!strcmp(s[i].material_spec[0], s[0].material_spec[0]));
        CHECK(am[i].lights.count == am[0].lights.count && am[i].ncameras == am[0].ncameras);
    }
    for (int i = 0; i < 3; i++) asset_model_free(&am[i]);
}

/* KHR_lights_punctual: positions through the node tree, candela / 683, the spot's cone; the point
 * light's irradiance at a point against I cos(theta) / d^2 written out. */
static void gltf_lights(void) {
    gbuf g;
    char rest[8192];
    quad_scene(&g, rest, sizeof rest);
    const char *path = tmp_path("lights.glb");
    write_gltf(path, &g, rest, true, NULL);
    prt_scene s;
    asset_model am;
    prt_error err;
    CHECK(load(path, NULL, &s, &am, &err) == 0, "%s", err.msg);
    CHECK(am.lights.count == 2, "%d lights (the directional one is skipped)", am.lights.count);
    if (am.lights.count != 2) { asset_model_free(&am); return; }
    const prt_light *pt = &am.lights.light[0], *sp = &am.lights.light[1];
    CHECK(pt->type == PRT_LIGHT_POINT && sp->type == PRT_LIGHT_SPOT);
    /* parent (1,0,0) + child (0,3,0): exact in float */
    CHECK(pt->pos[0] == 1.f && pt->pos[1] == 3.f && pt->pos[2] == 0.f, "%g %g %g", pt->pos[0], pt->pos[1], pt->pos[2]);
    CHECK_NEAR(pt->intensity, 1366.0 / 683.0, 2 * FLT_EPSILON * 2, "W/sr = cd / 683");
    CHECK_NEAR(pt->colour[1], 0.5, FLT_EPSILON);
    CHECK_NEAR(pt->colour[2], 0.25, FLT_EPSILON);
    CHECK_NEAR(sp->intensity, 1, 2 * FLT_EPSILON);
    CHECK_NEAR(sp->inner_deg, 0.3 * 180 / M_PI, 1e-5, "innerConeAngle (half-angle, radians)");
    CHECK_NEAR(sp->outer_deg, 0.6 * 180 / M_PI, 1e-5);
    /* -90 degrees about x turns -z to -y; the quaternion's 9 digits: 1e-8 */
    CHECK_NEAR(sp->dir[1], -1, 1e-6);
    CHECK_NEAR(sp->dir[2], 0, 1e-6);
    /* Irradiance on the quad (normal +y) at x = (1, 1, 0.5): I cos / d^2, with d = (0, 2, -0.5), for
     * the green channel (colour 0.5): a Lambert kd = 1 surface reflects E / pi. */
    brdf_params lam;
    CHECK(brdf_parse("lambert:kd=1", &lam, &err) == 0);
    const float x[3] = { 1, 1, 0.5f }, n[3] = { 0, 1, 0 }, wo[3] = { 0, 1, 0 };
    float wi[3], L[3];
    light_shade(pt, &lam, x, n, wo, wi, L);
    double d2 = 4 + 0.25, cosv = 2 / sqrt(d2), E = 2.0 * 0.5 * cosv / d2;
    /* a few float products and a square root: 1e-6 relative */
    CHECK_NEAR(L[1], E / M_PI, 1e-6 * E / M_PI, "green radiance under the point light");
    asset_model_free(&am);
}

/* The glTF camera: eye at its node, -z turned 30 degrees down, yfov in degrees. */
static void gltf_camera(void) {
    gbuf g;
    char rest[8192];
    quad_scene(&g, rest, sizeof rest);
    const char *path = tmp_path("cam.gltf");
    write_gltf(path, &g, rest, false, NULL);
    prt_scene s;
    asset_model am;
    prt_error err;
    CHECK(load(path, NULL, &s, &am, &err) == 0, "%s", err.msg);
    CHECK(am.ncameras == 1);
    if (am.ncameras != 1) { asset_model_free(&am); return; }
    const prt_camera *c = &am.cameras[0].cam;
    CHECK(!strcmp(am.cameras[0].name, "cam"), "name '%s'", am.cameras[0].name);
    CHECK(c->eye[0] == 0 && c->eye[1] == 2 && c->eye[2] == 5, "eye %g %g %g", c->eye[0], c->eye[1], c->eye[2]);
    float f[3];
    v3_sub(f, c->target, c->eye);
    v3_normalize(f);
    /* the quaternion's 9 digits and a float normalization: 1e-6 */
    CHECK_NEAR(f[0], 0, 1e-6);
    CHECK_NEAR(f[1], -0.5, 1e-6);
    CHECK_NEAR(f[2], -sqrt(0.75), 1e-6);
    CHECK_NEAR(c->fov_deg, 0.8 * 180 / M_PI, 1e-4, "yfov");
    asset_model_free(&am);
}

/* OBJ + MTL: Kd/Ks/Ns onto Phong, Kd alone onto Lambert, each face its usemtl's; without its MTL
 * file the OBJ keeps prt's own parser with a note. */
static void obj_mtl(void) {
    write_text(tmp_path("two.mtl"), "newmtl red\nKd 0.8 0.1 0.1\nKs 0.2 0.2 0.2\nNs 30\nnewmtl green\nKd 0.1 0.7 0.1\n");
    const char *obj = tmp_path("two.obj");
    write_text(obj, "mtllib two.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nv 3 0 0\nv 4 0 0\nv 4 0 1\n"
                    "usemtl red\nf 1 4 3\nf 1 3 2\nusemtl green\nf 5 7 6\n");
    prt_scene s;
    prt_error err;
    CHECK(scene_load(obj, NULL, &s, &err) == 0, "%s", err.msg);
    CHECK(s.nmaterials == 2 && s.mesh.ntris == 3, "%d materials, %d triangles", s.nmaterials, s.mesh.ntris);
    int red = -1, green = -1;
    for (int m = 0; m < s.nmaterials; m++) {
        if (s.materials[m].type == BRDF_PHONG) red = m;
        if (s.materials[m].type == BRDF_LAMBERT) green = m;
    }
    CHECK(red >= 0 && green >= 0);
    if (red >= 0 && green >= 0) {
        /* MTL decimals printed with 9 digits and parsed back: exact floats */
        CHECK(s.materials[red].kd[0] == 0.8f && s.materials[red].ks[1] == 0.2f && s.materials[red].n == 30.f);
        CHECK(s.materials[green].kd[1] == 0.7f);
        for (int v = 0; v < s.mesh.nverts; v++)   /* the green triangle is the one at x >= 3 */
            CHECK(s.mesh.mat[v] == (s.mesh.pos[3 * v] >= 3 ? green : red), "vertex %d", v);
        CHECK(strstr(s.material_from[red], "MTL Kd 0.8,0.1,0.1") != NULL, "%s", s.material_from[red]);
    }
    scene_free(&s);
    remove(tmp_path("two.mtl"));
    CHECK(scene_load(obj, NULL, &s, &err) == 0, "%s", err.msg);
    CHECK(s.nmaterials == 1 && s.mesh.nverts == 7 && strstr(s.notes, "MTL library") != NULL, "%d, notes %s", s.nmaterials, s.notes);
    scene_free(&s);
}

/* PLY: a quad face triangulated, the default material (PLY has none) or --material. */
static void ply(void) {
    const char *path = tmp_path("quad.ply");
    write_text(path, "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                     "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 0 1\n0 0 1\n4 0 3 2 1\n");
    prt_scene s;
    prt_error err;
    CHECK(scene_load(path, NULL, &s, &err) == 0, "%s", err.msg);
    CHECK(s.mesh.ntris == 2 && s.mesh.nverts == 4, "%d triangles", s.mesh.ntris);
    CHECK(s.nmaterials == 1 && !strcmp(s.material_spec[0], "lambert:kd=0.8"), "%s", s.material_spec[0]);
    CHECK(strstr(s.material_from[0], "default") != NULL);
    for (int v = 0; v < s.mesh.nverts; v++) CHECK_NEAR(s.mesh.nrm[3 * v + 1], 1, 4 * FLT_EPSILON, "smooth normal of a flat quad");
    scene_free(&s);
    scene_desc sd = { .material = "phong:kd=0.3;ks=0.2;n=10", .floor = 0 };
    CHECK(scene_load(path, &sd, &s, &err) == 0, "%s", err.msg);
    CHECK(s.nmaterials == 1 && s.materials[0].type == BRDF_PHONG && !strcmp(s.material_from[0], "--material"));
    scene_free(&s);
}

/* A JSON scene naming a glTF: its "material" wins, "translate" moves the mesh, lights and camera. */
static void json_names_gltf(void) {
    gbuf g;
    char rest[8192];
    quad_scene(&g, rest, sizeof rest);
    write_gltf(tmp_path("inscene.gltf"), &g, rest, false, NULL);
    const char *json = tmp_path("scene.json");
    write_text(json, "{\"models\":[{\"obj\":\"inscene.gltf\",\"translate\":[0,0,2],\"material\":\"lambert:kd=0.5\"}]}");
    prt_scene s;
    prt_error err;
    CHECK(scene_load(json, NULL, &s, &err) == 0, "%s", err.msg);
    CHECK(s.nmaterials == 1 && !strcmp(s.material_from[0], "models[0].material"), "%s", s.material_from[0]);
    CHECK(s.lights.count == 2 && s.lights.light[0].pos[2] == 2.f, "light z %g", s.lights.light[0].pos[2]);
    CHECK(s.ncameras == 1 && s.cameras[0].cam.eye[2] == 7.f, "camera z %g", s.cameras[0].cam.eye[2]);
    for (int v = 0; v < s.mesh.nverts; v++) CHECK(s.mesh.pos[3 * v + 2] >= 2.f);
    scene_free(&s);
}

/* Bad files: one line naming the file and the problem; lines skipped and morph targets noted. */
static void bad_inputs(void) {
    gbuf g;
    char rest[8192];
    prt_scene s;
    asset_model am;
    prt_error err;
    /* a .bin that is not there */
    quad_scene(&g, rest, sizeof rest);
    write_gltf(tmp_path("nobin.gltf"), &g, rest, false, "nobin.bin");
    remove(tmp_path("nobin.bin"));
    CHECK(load(tmp_path("nobin.gltf"), NULL, &s, &am, &err) == -1 && strstr(err.msg, "nobin.gltf") && strstr(err.msg, "nobin.bin"), "%s", err.msg);
    /* a texture that is not there */
    memset(&g, 0, sizeof g);
    const float uvs[8] = { 0, 0, 1, 0, 1, 1, 0, 1 };
    int pp = gb_add(&g, k_quad, sizeof k_quad, 5126, 4, "VEC3"), tc = gb_add(&g, uvs, sizeof uvs, 5126, 4, "VEC2");
    int pi = gb_add(&g, k_quad_idx, sizeof k_quad_idx, 5125, 6, "SCALAR");
    snprintf(rest, sizeof rest, "\"images\":[{\"uri\":\"absent.png\"}],\"textures\":[{\"source\":0}],\"materials\":[{"
             "\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0},\"metallicFactor\":0}}],\"meshes\":[{\"primitives\":[{\"attributes\":"
             "{\"POSITION\":%d,\"TEXCOORD_0\":%d},\"indices\":%d,\"material\":0}]}],\"nodes\":[{\"mesh\":0}],"
             "\"scenes\":[{\"nodes\":[0]}],\"scene\":0", pp, tc, pi);
    write_gltf(tmp_path("notex.gltf"), &g, rest, false, NULL);
    CHECK(load(tmp_path("notex.gltf"), NULL, &s, &am, &err) == -1 && strstr(err.msg, "notex.gltf") && strstr(err.msg, "absent.png"), "%s", err.msg);
    /* the same texture on a metal (glTF's default material: metallic 1): left out with a note, so
     * its absence is no error (prt's textures scale kd, and a metal has none) */
    snprintf(rest, sizeof rest, "\"images\":[{\"uri\":\"absent.png\"}],\"textures\":[{\"source\":0}],\"materials\":[{"
             "\"name\":\"gold\",\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}],\"meshes\":[{\"primitives\":"
             "[{\"attributes\":{\"POSITION\":%d,\"TEXCOORD_0\":%d},\"indices\":%d,\"material\":0}]}],\"nodes\":[{\"mesh\":0}],"
             "\"scenes\":[{\"nodes\":[0]}],\"scene\":0", pp, tc, pi);
    write_gltf(tmp_path("metaltex.gltf"), &g, rest, false, NULL);
    int mrc = load(tmp_path("metaltex.gltf"), NULL, &s, &am, &err);
    CHECK(mrc == 0 && s.ntextures == 0 && s.material_texture[0] == 0 && !am.mesh.uv &&
          strstr(s.notes, "metaltex.gltf: material 'gold': its base-colour texture is not used (metallic 1"), "%s%s", mrc ? err.msg : "", s.notes);
    if (mrc == 0) asset_model_free(&am);
    /* an index out of range (9 of 4 vertices) */
    memset(&g, 0, sizeof g);
    const uint32_t bad_idx[6] = { 0, 3, 2, 0, 2, 9 };
    int p = gb_add(&g, k_quad, sizeof k_quad, 5126, 4, "VEC3"), ix = gb_add(&g, bad_idx, sizeof bad_idx, 5125, 6, "SCALAR");
    snprintf(rest, sizeof rest, "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":%d},\"indices\":%d}]}],"
             "\"nodes\":[{\"mesh\":0}],\"scenes\":[{\"nodes\":[0]}],\"scene\":0", p, ix);
    write_gltf(tmp_path("range.glb"), &g, rest, true, NULL);
    CHECK(load(tmp_path("range.glb"), NULL, &s, &am, &err) == -1 && strstr(err.msg, "range.glb") && strstr(err.msg, "out of range"), "%s", err.msg);
    /* a triangle fan of 2 indices, and one without positions (assimp 5.2 made count - 2 faces in unsigned
     * arithmetic: 64 GB) */
    for (int k = 0; k < 2; k++) {
        memset(&g, 0, sizeof g);
        const uint32_t two[2] = { 0, 1 };
        p = gb_add(&g, k_quad, sizeof k_quad, 5126, 4, "VEC3"), ix = gb_add(&g, two, sizeof two, 5125, 2, "SCALAR");
        snprintf(rest, sizeof rest, "\"meshes\":[{\"primitives\":[{\"attributes\":{\"%s\":%d}%s,\"mode\":6}]}],"
                 "\"nodes\":[{\"mesh\":0}],\"scenes\":[{\"nodes\":[0]}],\"scene\":0", k ? "NORMAL" : "POSITION", p,
                 k ? "" : ",\"indices\":1");
        write_gltf(tmp_path("fan.gltf"), &g, rest, false, NULL);
        CHECK(load(tmp_path("fan.gltf"), NULL, &s, &am, &err) == -1 && strstr(err.msg, "fan.gltf: mesh 0 primitive 0: ") &&
              strstr(err.msg, k ? "no POSITION" : "fewer elements"), "%s", err.msg);
    }
    /* an infinite coordinate */
    memset(&g, 0, sizeof g);
    float inf_quad[12];
    memcpy(inf_quad, k_quad, sizeof inf_quad);
    inf_quad[4] = INFINITY;
    p = gb_add(&g, inf_quad, sizeof inf_quad, 5126, 4, "VEC3"), ix = gb_add(&g, k_quad_idx, sizeof k_quad_idx, 5125, 6, "SCALAR");
    snprintf(rest, sizeof rest, "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":%d},\"indices\":%d}]}],"
             "\"nodes\":[{\"mesh\":0}],\"scenes\":[{\"nodes\":[0]}],\"scene\":0", p, ix);
    write_gltf(tmp_path("inf.glb"), &g, rest, true, NULL);
    CHECK(load(tmp_path("inf.glb"), NULL, &s, &am, &err) == -1 && strstr(err.msg, "inf.glb") && strstr(err.msg, "non-finite"), "%s", err.msg);
    /* a schema failure: "scene" of the wrong type */
    write_text(tmp_path("schema.gltf"), "{\"asset\":{\"version\":\"2.0\"},\"scene\":\"zero\",\"scenes\":[{\"nodes\":[]}]}");
    CHECK(load(tmp_path("schema.gltf"), NULL, &s, &am, &err) == -1 && strstr(err.msg, "schema.gltf") && strstr(err.msg, "scene"), "%s", err.msg);
    /* lines only: no triangles; lines beside triangles: skipped with a note; a morph target: noted */
    memset(&g, 0, sizeof g);
    const float delta[12] = { 0 };
    p = gb_add(&g, k_quad, sizeof k_quad, 5126, 4, "VEC3"), ix = gb_add(&g, k_quad_idx, sizeof k_quad_idx, 5125, 6, "SCALAR");
    int dt = gb_add(&g, delta, sizeof delta, 5126, 4, "VEC3");
    snprintf(rest, sizeof rest, "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":%d},\"indices\":%d,\"mode\":1}]},"
             "{\"primitives\":[{\"attributes\":{\"POSITION\":%d},\"indices\":%d,\"targets\":[{\"POSITION\":%d}]}],\"weights\":[0.5]}],"
             "\"nodes\":[{\"mesh\":0},{\"mesh\":1}],\"scenes\":[{\"nodes\":[0]},{\"nodes\":[0,1]}],\"scene\":%%d", p, ix, p, ix, dt);
    char doc[8192];
    snprintf(doc, sizeof doc, rest, 0);
    write_gltf(tmp_path("lines.gltf"), &g, doc, false, NULL);
    CHECK(load(tmp_path("lines.gltf"), NULL, &s, &am, &err) == -1 && strstr(err.msg, "lines.gltf: no triangles"), "%s", err.msg);
    snprintf(doc, sizeof doc, rest, 1);
    write_gltf(tmp_path("mixed.gltf"), &g, doc, false, NULL);
    CHECK(load(tmp_path("mixed.gltf"), NULL, &s, &am, &err) == 0, "%s", err.msg);
    CHECK(am.mesh.ntris == 2 && strstr(s.notes, "points or lines skipped") && strstr(s.notes, "morphed"), "%d, notes %s", am.mesh.ntris, s.notes);
    asset_model_free(&am);
    /* through the CLI: exit 1, one line, no output */
    char cmd[2000], out[4096];
    const char *prt = tmp_path("bad.prt");
    snprintf(cmd, sizeof cmd, "%s precompute %s -o %s", check_prt_bin(), tmp_path("range.glb"), prt);
    int rc = check_run(cmd, out, sizeof out);
    struct stat st;
    CHECK(rc == 1 && strchr(out, '\n') == out + strlen(out) - 1 && stat(prt, &st) != 0, "rc %d: %s", rc, out);
}

/* Debian's assimp-testmodels: BoxTextured as .gltf + .bin, .glb and embedded .gltf, one mesh. */
static void testmodels_box_textured(void) {
    const char *v[3] = { TESTMODELS "/BoxTextured-glTF/BoxTextured.gltf", TESTMODELS "/BoxTextured-glTF-Binary/BoxTextured.glb",
                         TESTMODELS "/BoxTextured-glTF-Embedded/BoxTextured.gltf" };
    prt_scene s[3];
    asset_model am[3];
    prt_error err;
    for (int i = 0; i < 3; i++) CHECK(load(v[i], NULL, &s[i], &am[i], &err) == 0, "%s", err.msg);
    CHECK(am[0].mesh.ntris == 12 && am[0].mesh.nverts == 24, "%d triangles, %d vertices", am[0].mesh.ntris, am[0].mesh.nverts);
    for (int i = 1; i < 3; i++) {
        /* the same buffer bytes through the same code: identical */
        CHECK(am[i].mesh.nverts == am[0].mesh.nverts && am[i].mesh.ntris == am[0].mesh.ntris);
        if (am[i].mesh.nverts != am[0].mesh.nverts || am[i].mesh.ntris != am[0].mesh.ntris) continue;
        CHECK(!memcmp(am[i].mesh.pos, am[0].mesh.pos, 12 * (size_t)am[0].mesh.nverts), "%s positions", v[i]);
        CHECK(!memcmp(am[i].mesh.nrm, am[0].mesh.nrm, 12 * (size_t)am[0].mesh.nverts), "%s normals", v[i]);
        CHECK(!memcmp(am[i].mesh.tris, am[0].mesh.tris, 12 * (size_t)am[0].mesh.ntris), "%s triangles", v[i]);
        CHECK(!strcmp(s[i].material_spec[0], s[0].material_spec[0]), "%s", s[i].material_spec[0]);
        /* one PNG: beside the file, in the .glb's buffer, in a data URI; decoded alike */
        CHECK(s[i].ntextures == 1 && s[0].ntextures == 1 && s[i].material_texture[0] == 1);
        if (s[i].ntextures == 1 && s[0].ntextures == 1) {
            const scene_texture *a = &s[i].textures[0], *b = &s[0].textures[0];
            CHECK(a->w == b->w && a->h == b->h && !memcmp(a->srgb, b->srgb, 3 * (size_t)a->w * a->h), "%s texels", v[i]);
            CHECK(!memcmp(am[i].mesh.uv, am[0].mesh.uv, 8 * (size_t)am[0].mesh.nverts), "%s coordinates", v[i]);
        }
    }
    for (int i = 0; i < 3; i++) {
        asset_model_free(&am[i]);
        scene_free(&s[i]);
    }
}

/* The file keeps the glTF's camera: prt info lists it, --camera-name picks it or says which exist. */
static void cli_cameras(void) {
    gbuf g;
    char rest[8192], cmd[3000], out[8192];
    quad_scene(&g, rest, sizeof rest);
    write_gltf(tmp_path("clicam.glb"), &g, rest, true, NULL);
    const char *prt = tmp_path("clicam.prt");
    snprintf(cmd, sizeof cmd, "%s precompute %s --material lambert:kd=0.5 --no-bounces -o %s", check_prt_bin(), tmp_path("clicam.glb"), prt);
    CHECK(check_run(cmd, out, sizeof out) == 0, "%s", out);
    CHECK(strstr(out, "from --material") != NULL, "%s", out);
    snprintf(cmd, sizeof cmd, "%s info %s", check_prt_bin(), prt);
    CHECK(check_run(cmd, out, sizeof out) == 0 && strstr(out, "cameras      'cam' eye 0,2,5"), "%s", out);
    snprintf(cmd, sizeof cmd, "%s render %s --probe none --camera-name nope -o %s", check_prt_bin(), prt, tmp_path("x.png"));
    CHECK(check_run(cmd, out, sizeof out) == 2 && strstr(out, "no camera of that name (the file's: 'cam')"), "%s", out);
}


/* ---------------------------------------------------------------- textures */

/* The 8-bit sRGB code of linear x and its linear value again (IEC 61966-2-1, written out here). */
static double srgb8_linear(double x) {
    double e = x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1 / 2.4) - 0.055;
    double c = floor(255 * e + 0.5) / 255;
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

static const double k_check[2][3] = { { 0.8, 0.25, 0.1 }, { 0.1, 0.3, 0.7 } };   /* the checker's two albedos */

/* An 8 x 8 checker PNG (texel (x, y) colour (x + y) & 1), a quad OBJ of 9 x 9 vertices over [0,1]^2
 * (y = 0, facing +y) whose vertex (i, j) has uv ((i + 0.5) / 8, (j + 0.5) / 8) ... at texel centres
 * for i, j < 8, and two MTLs: Kd 1 with map_Kd, and Kd 1 alone. */
static void checker_files(void) {
    prt_image im;
    prt_error err;
    CHECK(image_alloc(&im, 8, 8, 3, &err) == 0);
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 8; x++)
            for (int c = 0; c < 3; c++) im.data[3 * (8 * y + x) + c] = (float)k_check[(x + y) & 1][c];
    image_desc d = { 0 };
    CHECK(image_write(tmp_path("checker.png"), &im, &d, &err) == 0, "%s", err.msg);
    image_free(&im);
    write_text(tmp_path("tex.mtl"), "newmtl t\nKd 1 1 1\nmap_Kd checker.png\n");
    write_text(tmp_path("plain.mtl"), "newmtl t\nKd 1 1 1\n");
    for (int f = 0; f < 2; f++) {
        FILE *o = fopen(tmp_path(f ? "plainquad.obj" : "texquad.obj"), "w");
        fprintf(o, "mtllib %s\n", f ? "plain.mtl" : "tex.mtl");
        for (int j = 0; j < 9; j++)
            for (int i = 0; i < 9; i++) fprintf(o, "v %g 0 %g\nvt %.9g %.9g\n", i / 8.0, j / 8.0, (i + 0.5) / 8, (j + 0.5) / 8);
        fprintf(o, "usemtl t\n");
        for (int j = 0; j < 8; j++)
            for (int i = 0; i < 8; i++) {
                int a = 9 * j + i + 1;
                fprintf(o, "f %d/%d %d/%d %d/%d\nf %d/%d %d/%d %d/%d\n", a, a, a + 9, a + 9, a + 10, a + 10, a, a, a + 10, a + 10, a + 1, a + 1);
            }
        fclose(o);
    }
}

/* The texture loads texel for texel, each vertex at a texel centre reads that texel, and the
 * triangle means of the whole quad average to the checker's mean. */
static void texture_checker(void) {
    checker_files();
    prt_scene s;
    prt_error err;
    CHECK(scene_load(tmp_path("texquad.obj"), NULL, &s, &err) == 0, "%s", err.msg);
    CHECK(s.ntextures == 1 && s.textures[0].w == 8 && s.textures[0].h == 8 && s.mesh.uv, "%d textures", s.ntextures);
    CHECK(s.nmaterials == 1 && s.material_texture[0] == 1 && strstr(s.material_from[0], "checker.png"), "%s", s.material_from[0]);
    if (s.ntextures != 1 || !s.mesh.uv) { scene_free(&s); return; }
    int checked = 0;
    for (int v = 0; v < s.mesh.nverts; v++) {
        int i = (int)lrint(s.mesh.pos[3 * v] * 8), j = (int)lrint(s.mesh.pos[3 * v + 2] * 8);
        if (i > 7 || j > 7) continue;
        float a[3];
        scene_vertex_albedo(&s, v, a);
        /* v = (j + 0.5) / 8 is texel row 7 - j (row 0 at v = 1), column i: the PNG's texel ((i + 7 - j) & 1) */
        for (int c = 0; c < 3; c++) CHECK_NEAR(a[c], srgb8_linear(k_check[(i + 7 - j) & 1][c]), 1e-6, "vertex %d (%d, %d)", v, i, j);
        checked++;
    }
    CHECK(checked == 64, "%d vertices at texel centres", checked);
    /* the bilinear, repeat-wrapped checker averages to its texel mean over the whole square; each
     * triangle mean is a quadrature of 1 sample a texel (texture.h) but the 128 triangles together
     * sample every texel's neighbourhood alike: their mean within 1/64 of the contrast */
    double mean[3] = { 0, 0, 0 };
    for (int t = 0; t < s.mesh.ntris; t++) {
        float a[3];
        scene_triangle_albedo(&s, t, a);
        for (int c = 0; c < 3; c++) mean[c] += a[c] / s.mesh.ntris;
    }
    for (int c = 0; c < 3; c++) {
        double c0 = srgb8_linear(k_check[0][c]), c1 = srgb8_linear(k_check[1][c]);
        CHECK_NEAR(mean[c], 0.5 * (c0 + c1), fabs(c0 - c1) / 64, "channel %d", c);
    }
    scene_free(&s);
}

/* Mean of channel c of an EXR's pixels. */
static double image_mean(const char *path, int c) {
    prt_image im;
    prt_error err;
    if (image_read(path, &im, &err)) return NAN;
    double m = 0;
    for (int i = 0; i < im.w * im.h; i++) m += im.data[3 * i + c];
    m /= im.w * im.h;
    image_free(&im);
    return m;
}

/* Through the CLI under a constant probe: the textured quad's vertex radiance is its untextured
 * twin's times the texel (the transport is the same: the texture multiplies at shading), and its
 * per-pixel image over the middle 6 x 6 texels averages to the checker's mean times the twin's. */
static void texture_constant_probe(void) {
    checker_files();
    prt_image pr;
    prt_error err;
    CHECK(image_alloc(&pr, 64, 32, 3, &err) == 0);
    for (int i = 0; i < 64 * 32 * 3; i++) pr.data[i] = 1;
    image_desc d = { 0 };
    CHECK(image_write(tmp_path("white.exr"), &pr, &d, &err) == 0, "%s", err.msg);
    image_free(&pr);
    char cmd[4000], out[8192];
    const char *names[2] = { "texquad", "plainquad" };
    for (int f = 0; f < 2; f++) {
        snprintf(cmd, sizeof cmd, "%s precompute %s/%s.obj --no-bounces -o %s/%s.prt && %s render %s/%s.prt --probe %s "
                 "--vertices %s/%s.csv --camera 0.5,2,0.5,0.5,0,0.5,21.2397 --size 60x60 --no-background -o %s/%s.exr",
                 check_prt_bin(), check_tmpdir(), names[f], check_tmpdir(), names[f], check_prt_bin(), check_tmpdir(), names[f],
                 tmp_path("white.exr"), check_tmpdir(), names[f], check_tmpdir(), names[f]);
        CHECK(check_run(cmd, out, sizeof out) == 0, "%s", out);
    }
    snprintf(cmd, sizeof cmd, "%s info %s/texquad.prt", check_prt_bin(), check_tmpdir());
    CHECK(check_run(cmd, out, sizeof out) == 0 && strstr(out, "textures     'checker.png' 8x8"), "%s", out);
    /* vertex CSVs: id, then r, g, b (prt render --vertices) */
    char *ct = check_read_file(tmp_path("texquad.csv"), NULL), *cp = check_read_file(tmp_path("plainquad.csv"), NULL);
    prt_scene s;   /* the vertex order of the files (no floor, no refinement) */
    CHECK(scene_load(tmp_path("texquad.obj"), NULL, &s, &err) == 0, "%s", err.msg);
    CHECK(ct && cp);
    int n = 0;
    const char *a = ct ? strchr(ct, '\n') : NULL, *b = cp ? strchr(cp, '\n') : NULL;   /* past the header */
    for (; a && b && a[1] && b[1]; a = strchr(a + 1, '\n'), b = strchr(b + 1, '\n')) {
        int va, vb;
        double x[3], y[3];
        if (sscanf(a + 1, "%d,%lf,%lf,%lf", &va, &x[0], &x[1], &x[2]) != 4 || sscanf(b + 1, "%d,%lf,%lf,%lf", &vb, &y[0], &y[1], &y[2]) != 4) continue;
        n++;
        CHECK(va == vb && va >= 0 && va < s.mesh.nverts);
        if (va != vb || va < 0 || va >= s.mesh.nverts) continue;
        /* vertex (i, j) samples texel column i mod 8, row 7 - j mod 8 (repeat), at its centre */
        int i = (int)lrint(s.mesh.pos[3 * va] * 8) % 8, j = (int)lrint(s.mesh.pos[3 * va + 2] * 8) % 8;
        /* the same transport both sides; the CSV's 8 digits and a float product: 1e-6 relative */
        for (int c = 0; c < 3; c++) CHECK_NEAR(x[c], srgb8_linear(k_check[(i + 7 - j) & 1][c]) * y[c], 1e-6 * y[c] + 1e-7, "vertex %d", va);
    }
    scene_free(&s);
    CHECK(n >= 81, "%d vertex rows", n);
    free(ct), free(cp);
    for (int c = 0; c < 3; c++) {
        double c0 = srgb8_linear(k_check[0][c]), c1 = srgb8_linear(k_check[1][c]);
        double mt = image_mean(tmp_path("texquad.exr"), c), mp = image_mean(tmp_path("plainquad.exr"), c);
        /* 10 pixels a texel, uniform in uv: the bilinear checker averages to its texel mean; GL's
         * filter weights have 8 fractional bits (1/256 of the contrast) */
        CHECK_NEAR(mt / mp, 0.5 * (c0 + c1), fabs(c0 - c1) / 256 + 1e-6, "channel %d: %g / %g", c, mt, mp);
    }
}

/* The texel-mean ratio test: the mean over the pixels of image a over image b (where b > 0) in channel
 * c; NAN when either cannot be read or their sizes differ. */
static double ratio_mean(const char *a, const char *b, int c) {
    prt_image x, y;
    prt_error err;
    if (image_read(a, &x, &err)) return NAN;
    if (image_read(b, &y, &err)) { image_free(&x); return NAN; }
    double m = 0;
    int n = 0;
    for (int i = 0; i < x.w * x.h && x.w == y.w && x.h == y.h; i++)
        if (y.data[3 * i + c] > 0) m += x.data[3 * i + c] / y.data[3 * i + c], n++;
    image_free(&x), image_free(&y);
    return n ? m / n : NAN;
}

/* The largest |a - b| over the pixels of channel c relative to b's mean; NAN as ratio_mean. */
static double max_rel_diff(const char *a, const char *b, int c) {
    prt_image x, y;
    prt_error err;
    if (image_read(a, &x, &err)) return NAN;
    if (image_read(b, &y, &err)) { image_free(&x); return NAN; }
    double d = NAN, mean = 0;
    if (x.w == y.w && x.h == y.h) {
        d = 0;
        for (int i = 0; i < x.w * x.h; i++) mean += y.data[3 * i + c] / (x.w * x.h);
        for (int i = 0; i < x.w * x.h; i++) d = fmax(d, fabs(x.data[3 * i + c] - y.data[3 * i + c]));
        d /= mean;
    }
    image_free(&x), image_free(&y);
    return d;
}

/* The textured quad through the gl backend's per-pixel path (glrt: the texture sampled in the view
 * shader): under the constant probe, pixel for pixel the cpu backend's image and the checker's mean
 * over its untextured twin. Then a point light over both quads, no probe: each textured vertex's
 * radiance is its texel times kd/pi I cos / d^2 (the light's direct term with the texture on kd,
 * analytic), and in both backends' images every pixel over its twin's pixel is the texture there, so
 * the ratio averages to the checker's mean. */
static void texture_gl_and_lights(void) {
    checker_files();
    prt_image pr;
    prt_error err;
    CHECK(image_alloc(&pr, 64, 32, 3, &err) == 0);
    for (int i = 0; i < 64 * 32 * 3; i++) pr.data[i] = 1;
    image_desc d = { 0 };
    CHECK(image_write(tmp_path("white.exr"), &pr, &d, &err) == 0, "%s", err.msg);
    image_free(&pr);
    char cmd[4000], out[8192];
    const char *names[2] = { "texquad", "plainquad" }, *backends[2] = { "cpu", "gl" };
    const char *cam = "--camera 0.5,2,0.5,0.5,0,0.5,21.2397 --size 60x60 --no-background";
    const double I = 2, h = 1;   /* the light: 2 W/sr, 1 above the quad's centre */
    for (int f = 0; f < 2; f++) {
        snprintf(cmd, sizeof cmd, "%s precompute %s/%s.obj --no-bounces -o %s/%s.prt", check_prt_bin(), check_tmpdir(), names[f],
                 check_tmpdir(), names[f]);
        CHECK(check_run(cmd, out, sizeof out) == 0, "%s", out);
        for (int b = 0; b < 2; b++) {
            snprintf(cmd, sizeof cmd, "%s render %s/%s.prt --backend %s --probe %s %s -o %s/%s_%s.exr && "
                     "%s render %s/%s.prt --backend %s --probe none --light 'point:pos=0.5,%g,0.5;intensity=%g' %s "
                     "--vertices %s/%s_light.csv -o %s/%s_light_%s.exr", check_prt_bin(), check_tmpdir(), names[f], backends[b],
                     tmp_path("white.exr"), cam, check_tmpdir(), names[f], backends[b], check_prt_bin(), check_tmpdir(), names[f],
                     backends[b], h, I, cam, check_tmpdir(), names[f], check_tmpdir(), names[f], backends[b]);
            CHECK(check_run(cmd, out, sizeof out) == 0, "%s", out);
        }
    }
    for (int c = 0; c < 3; c++) {
        double c0 = srgb8_linear(k_check[0][c]), c1 = srgb8_linear(k_check[1][c]), mean = 0.5 * (c0 + c1);
        /* the cpu raster's GL filter: weights with 8 fraction bits, 1/256 of the contrast per axis */
        double filt = fabs(c0 - c1) / 256;
        CHECK_NEAR(max_rel_diff(tmp_path("texquad_gl.exr"), tmp_path("texquad_cpu.exr"), c), 0, 2 * filt / mean + 1e-5, "channel %d", c);
        CHECK_NEAR(ratio_mean(tmp_path("texquad_gl.exr"), tmp_path("plainquad_gl.exr"), c), mean, filt + 1e-6, "channel %d", c);
        for (int b = 0; b < 2; b++) {
            char t[64], u[64];
            snprintf(t, sizeof t, "texquad_light_%s.exr", backends[b]);
            snprintf(u, sizeof u, "plainquad_light_%s.exr", backends[b]);
            char tp[1024];
            snprintf(tp, sizeof tp, "%s", tmp_path(t));
            CHECK_NEAR(ratio_mean(tp, tmp_path(u), c), mean, filt + 1e-6, "%s channel %d", backends[b], c);
        }
    }
    /* the vertex CSV (the cpu backend's last run): texel x kd/pi I cos / d^2, kd = 1 (MTL Kd 1) */
    char *csv = check_read_file(tmp_path("texquad_light.csv"), NULL);
    prt_scene s;
    CHECK(scene_load(tmp_path("texquad.obj"), NULL, &s, &err) == 0, "%s", err.msg);
    int n = 0;
    for (const char *a = csv ? strchr(csv, '\n') : NULL; a && a[1]; a = strchr(a + 1, '\n')) {
        int v;
        double x[3];
        if (sscanf(a + 1, "%d,%lf,%lf,%lf", &v, &x[0], &x[1], &x[2]) != 4 || v < 0 || v >= s.mesh.nverts) continue;
        n++;
        const float *p = s.mesh.pos + 3 * (size_t)v;
        double d2 = (p[0] - 0.5) * (p[0] - 0.5) + h * h + (p[2] - 0.5) * (p[2] - 0.5), E = I * (h / sqrt(d2)) / d2;
        int i = (int)lrint(p[0] * 8) % 8, j = (int)lrint(p[2] * 8) % 8;
        /* float arithmetic on both sides and the CSV's 8 digits: 1e-5 relative */
        for (int c = 0; c < 3; c++) {
            double want = srgb8_linear(k_check[(i + 7 - j) & 1][c]) * E / M_PI;
            CHECK_NEAR(x[c], want, 1e-5 * want, "vertex %d channel %d", v, c);
        }
    }
    CHECK(n >= 81, "%d vertex rows", n);
    scene_free(&s);
    free(csv);
}

/* Reads prt render's vertex CSV (id, r, g, b) into rgb[3 * n] by id; the rows read, or -1. */
static int read_vertex_csv(const char *path, double *rgb, int n) {
    char *t = check_read_file(path, NULL);
    if (!t) return -1;
    int rows = 0;
    for (const char *a = strchr(t, '\n'); a && a[1]; a = strchr(a + 1, '\n')) {
        int v;
        double x[3];
        if (sscanf(a + 1, "%d,%lf,%lf,%lf", &v, &x[0], &x[1], &x[2]) == 4 && v >= 0 && v < n) {
            memcpy(rgb + 3 * v, x, sizeof x);
            rows++;
        }
    }
    free(t);
    return rows;
}

/* A texture scales kd, never the lobe: the checker quad with a purely specular MTL material (Kd 0,
 * Ks 0.5, Ns 200) under the constant probe. On the vMF path (--glossy vmf: the sparse transfer holds
 * kd's part, zero here; the lobes the rest) every vertex's radiance equals its untextured twin's:
 * the highlight's colour does not depend on the texture. On the SVD path, which cannot split kd from
 * the lobe (docs/design/assets.md), it is the twin's times the texel: the stated approximation. */
static void texture_specular_paths(void) {
    checker_files();
    write_text(tmp_path("spec.mtl"), "newmtl t\nKd 0 0 0\nKs 0.5 0.5 0.5\nNs 200\nmap_Kd checker.png\n");
    write_text(tmp_path("specplain.mtl"), "newmtl t\nKd 0 0 0\nKs 0.5 0.5 0.5\nNs 200\n");
    char *quad = check_read_file(tmp_path("texquad.obj"), NULL);
    CHECK(quad && !strncmp(quad, "mtllib tex.mtl\n", 15));
    if (!quad || strncmp(quad, "mtllib tex.mtl\n", 15)) { free(quad); return; }
    for (int f = 0; f < 2; f++) {
        char text[65536];
        snprintf(text, sizeof text, "mtllib %s\n%s", f ? "specplain.mtl" : "spec.mtl", quad + 15);
        write_text(tmp_path(f ? "specplain.obj" : "spec.obj"), text);
    }
    free(quad);
    prt_image pr;
    prt_error err;
    CHECK(image_alloc(&pr, 64, 32, 3, &err) == 0);
    for (int i = 0; i < 64 * 32 * 3; i++) pr.data[i] = 1;
    image_desc d = { 0 };
    CHECK(image_write(tmp_path("white.exr"), &pr, &d, &err) == 0, "%s", err.msg);
    image_free(&pr);
    prt_scene s;
    CHECK(scene_load(tmp_path("texquad.obj"), NULL, &s, &err) == 0, "%s", err.msg);
    int n = s.mesh.nverts;
    double *rgb = calloc(4 * 3 * (size_t)n, sizeof(double));   /* [path][textured] */
    const char *paths[2] = { "vmf", "svd" }, *names[2] = { "spec", "specplain" };
    char cmd[4000], out[8192];
    for (int p = 0; p < 2; p++)
        for (int f = 0; f < 2; f++) {
            snprintf(cmd, sizeof cmd, "%s precompute %s/%s.obj --glossy %s --no-bounces -o %s/%s_%s.prt && %s render %s/%s_%s.prt "
                     "--probe %s --vertices %s/%s_%s.csv --camera 0.5,2,0.5,0.5,0,0.5,21.2397 --size 60x60 -o %s/%s_%s.exr",
                     check_prt_bin(), check_tmpdir(), names[f], paths[p], check_tmpdir(), names[f], paths[p], check_prt_bin(),
                     check_tmpdir(), names[f], paths[p], tmp_path("white.exr"), check_tmpdir(), names[f], paths[p], check_tmpdir(),
                     names[f], paths[p]);
            CHECK(check_run(cmd, out, sizeof out) == 0, "%s", out);
            char csv[256];
            snprintf(csv, sizeof csv, "%s_%s.csv", names[f], paths[p]);
            CHECK(rgb && read_vertex_csv(tmp_path(csv), rgb + 3 * (size_t)n * (2 * p + f), n) >= 81, "%s", csv);
        }
    for (int v = 0; v < n && rgb; v++) {
        int i = (int)lrint(s.mesh.pos[3 * v] * 8) % 8, j = (int)lrint(s.mesh.pos[3 * v + 2] * 8) % 8;
        for (int c = 0; c < 3; c++) {
            double vt = rgb[3 * (size_t)v + c], vp = rgb[3 * ((size_t)n + v) + c];
            double st = rgb[3 * (2 * (size_t)n + v) + c], sp = rgb[3 * (3 * (size_t)n + v) + c];
            /* the same transport each pair: the CSV's 8 digits and a float product */
            CHECK_NEAR(vt, vp, 1e-6 * vp + 1e-7, "vmf: vertex %d channel %d", v, c);
            CHECK_NEAR(st, srgb8_linear(k_check[(i + 7 - j) & 1][c]) * sp, 1e-6 * sp + 1e-7, "svd: vertex %d channel %d", v, c);
        }
    }
    CHECK(rgb && rgb[3 * (size_t)n / 2] > 0.01, "no highlight (%g)", rgb ? rgb[3 * (size_t)n / 2] : 0);
    free(rgb);
    scene_free(&s);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(gltf_metallic_roughness);
    CHECK_CASE(gltf_variants_agree);
    CHECK_CASE(gltf_lights);
    CHECK_CASE(gltf_camera);
    CHECK_CASE(obj_mtl);
    CHECK_CASE(ply);
    CHECK_CASE(json_names_gltf);
    CHECK_CASE(bad_inputs);
    struct stat st;
    if (stat(TESTMODELS "/BoxTextured-glTF-Binary/BoxTextured.glb", &st) == 0) CHECK_CASE(testmodels_box_textured);
    else check_skip("testmodels_box_textured", "assimp-testmodels is not installed (" TESTMODELS ")");
    CHECK_CASE(cli_cameras);
    CHECK_CASE(texture_checker);
    CHECK_CASE_GL(texture_constant_probe);
    CHECK_CASE_GL(texture_gl_and_lights);
    CHECK_CASE_GL(texture_specular_paths);
    return check_summary();
}
