/* asset.c - glTF 2.0, PLY and OBJ + MTL models through assimp's C API (see asset.h).
 *
 * assimp reads the file into an aiScene; this file walks its node tree, copies each triangle
 * mesh instance into prt's one mesh in world space, maps the materials onto prt's BRDFs and
 * converts lights and cameras. Two things assimp does not tell are read from the glTF's own
 * JSON (cJSON): the extensions it uses (so an ignored KHR_materials_* is named) and how many
 * triangles its accessors hold (assimp drops a triangle with an index out of range with only a
 * log line; prt refuses the file instead, the count telling). */
#include "asset.h"
#include "image.h"
#include "vec3.h"
#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define ASSET_DEFAULT_MATERIAL "lambert:kd=0.8"
#define ASSET_DEGENERATE_REL 1e-12    /* mesh.c's MESH_DEGENERATE_REL */
#define ASSET_MAX_ELEMS (1 << 28)     /* mesh.c's MESH_MAX_ELEMS */
#define ASSET_MAX_JSON (1 << 30)      /* a glTF's JSON read to inspect it */
#define ASSET_ALPHA_MIN 0.001f        /* brdf.h's smallest alpha */

typedef enum asset_format { FMT_GLTF, FMT_PLY, FMT_OBJ } asset_format;

/* What the glTF's JSON says beside assimp: its triangle count (-1: not counted). */
typedef struct gltf_info {
    long long triangles;
    char external[128];   /* the first buffer or image URI that names a file ("": none) */
    char invalid[256];    /* the first problem gltf_validate found ("": none): refused before assimp */
    long long bin_len;    /* a .glb's BIN chunk length (-1: none) */
    bool json_ok;         /* its JSON parsed to an object: a glTF (else assimp would try other readers) */
    const char *path;     /* the file (its folder anchors external URIs), NULL in memory */
} gltf_info;

/* One load: the file's name for errors, its format, the caller's choices and the outputs. */
typedef struct loader {
    const char *name;
    asset_format fmt;
    const asset_desc *desc;
    prt_scene *s;
    asset_model *out;
    prt_error *err;
    const struct aiScene *ai;
    int *mat_index;             /* [mNumMaterials]: the scene material of each, -1 not made yet */
    unsigned *mat_uv;           /* [mNumMaterials]: the UV channel its texture reads */
    bool textured;              /* some material has a texture: the mesh keeps its UVs */
    bool from_memory;           /* asset_load_memory: no folder to open files in */
    size_t cap_v, cap_t;        /* capacity of out->mesh's arrays */
    bool need_normals;          /* some vertex had no usable normal: computed for those */
    unsigned char *bad_normal;  /* [cap_v]: 1 where the normal is computed */
    int skipped_prims, skinned, morphed;
} loader;

void asset_model_free(asset_model *m) {
    mesh_free(&m->mesh);
    memset(m, 0, sizeof *m);
}

bool asset_handles(const char *path) {
    char ext[16];
    prt_path_ext(path, ext);
    return !strcmp(ext, "gltf") || !strcmp(ext, "glb") || !strcmp(ext, "ply");
}

/* The file's base name (errors name the path; notes the base, to stay short). */
static const char *base_name(const char *p) {
    const char *sl = strrchr(p, '/');
    return sl ? sl + 1 : p;
}

/* ---------------------------------------------------------------- the glTF's JSON */

/* The JSON text of a glTF held in buf[len]: all of a .gltf, the first chunk of a .glb (its
 * 12-byte header "glTF", version 2, total length; then chunk length, type "JSON", bytes; then
 * optionally a "BIN" chunk, its length into gi->bin_len). A .glb whose lengths disagree with len
 * is invalid (gi->invalid; assimp would allocate what a forged length says). */
static const char *gltf_json(const unsigned char *buf, size_t len, size_t *jlen, gltf_info *gi) {
    gi->bin_len = -1;
    *jlen = len;
    if (len < 4 || memcmp(buf, "glTF", 4)) return (const char *)buf;
    uint32_t h[5] = { 0 };
    for (int i = 0; i < 5 && 4 * (size_t)i + 4 <= len; i++)
        h[i] = (uint32_t)buf[4 * i] | (uint32_t)buf[4 * i + 1] << 8 | (uint32_t)buf[4 * i + 2] << 16 | (uint32_t)buf[4 * i + 3] << 24;
    if (len < 20 || h[1] != 2 || h[2] != len || memcmp(buf + 16, "JSON", 4) || h[3] > len - 20) {
        snprintf(gi->invalid, sizeof gi->invalid, "not a valid glTF 2.0 binary header (version %u, length %u of %zu bytes, "
                 "JSON chunk %u bytes)", h[1], h[2], len, h[3]);
        return NULL;
    }
    size_t at = 20 + (size_t)h[3];
    if (len - at >= 8) {
        uint32_t bl = (uint32_t)buf[at] | (uint32_t)buf[at + 1] << 8 | (uint32_t)buf[at + 2] << 16 | (uint32_t)buf[at + 3] << 24;
        if (bl > len - at - 8) {
            snprintf(gi->invalid, sizeof gi->invalid, "its BIN chunk says %u bytes, %zu follow", bl, len - at - 8);
            return NULL;
        }
        if (!memcmp(buf + at + 4, "BIN", 4)) gi->bin_len = bl;
    }
    *jlen = h[3];
    return (const char *)buf + 20;
}

/* Triangles one primitive's accessors hold: indices (or POSITION) count by mode (4: n/3; 5, 6
 * strips and fans: n - 2); 0 for points and lines (modes 0-3). */
static long long prim_triangles(const cJSON *prim, const cJSON *accessors) {
    const cJSON *mode = cJSON_GetObjectItemCaseSensitive(prim, "mode");
    int md = cJSON_IsNumber(mode) ? mode->valueint : 4;
    if (md < 4 || md > 6) return 0;
    const cJSON *ix = cJSON_GetObjectItemCaseSensitive(prim, "indices");
    if (!cJSON_IsNumber(ix)) ix = cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(prim, "attributes"), "POSITION");
    const cJSON *acc = cJSON_IsNumber(ix) ? cJSON_GetArrayItem(accessors, ix->valueint) : NULL;
    const cJSON *cnt = cJSON_GetObjectItemCaseSensitive(acc, "count");
    long long n = cJSON_IsNumber(cnt) && cnt->valuedouble >= 0 && cnt->valuedouble < 1e15 ? (long long)cnt->valuedouble : 0;
    return md == 4 ? n / 3 : n >= 3 ? n - 2 : 0;
}

/* A non-negative integer member below 2^50, or def when absent; -1 when present but not one. */
static long long jint(const cJSON *o, const char *key, long long def) {
    const cJSON *it = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!it) return def;
    double d = cJSON_IsNumber(it) ? it->valuedouble : -1;
    return d >= 0 && d < 1125899906842624.0 && d == floor(d) ? (long long)d : -1;
}

/* The bytes a base64 data URI decodes to, or -1 when it is not one (another encoding, a character
 * outside base64's alphabet, a length not a multiple of 4): assimp 5.2 decodes up to the first bad
 * character and then copies the byteLength the file declares. */
static long long data_uri_bytes(const char *u) {
    const char *comma = strchr(u, ','), *b64 = strstr(u, ";base64,");
    if (!comma || !b64 || b64 + 7 != comma) return -1;
    size_t n = strlen(comma + 1), pad = 0;
    for (size_t i = 0; i < n; i++) {
        char c = comma[1 + i];
        bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' || c == '/';
        if (c == '=' && i + 2 >= n) pad++;
        else if (!ok) return -1;
    }
    return n % 4 ? -1 : (long long)(n / 4 * 3 - pad);
}

/* Bytes buffer b can hold: the .glb's BIN chunk (no uri), a data URI's decoded payload, a file's size
 * (file mode; -1 when it cannot be read: assimp names the missing file). */
static long long buffer_bytes(const cJSON *b, const gltf_info *gi) {
    const cJSON *uri = cJSON_GetObjectItemCaseSensitive(b, "uri");
    if (!cJSON_IsString(uri)) return gi->bin_len;
    const char *u = uri->valuestring;
    if (!strncmp(u, "data:", 5)) return data_uri_bytes(u);
    if (!gi->path) return -1;
    char full[4096];
    const char *slash = strrchr(gi->path, '/');
    snprintf(full, sizeof full, "%.*s%s%s", slash ? (int)(slash - gi->path) : 0, gi->path, slash ? "/" : "", u);
    struct stat sb;
    return stat(full, &sb) == 0 && S_ISREG(sb.st_mode) ? (long long)sb.st_size : -1;
}

/* Element bytes of an accessor (component size x components), 0 when its types are unknown. */
static long long element_bytes(const cJSON *a) {
    static const struct { const char *t; int n; } k[] = { { "SCALAR", 1 }, { "VEC2", 2 }, { "VEC3", 3 }, { "VEC4", 4 },
                                                         { "MAT2", 4 }, { "MAT3", 9 }, { "MAT4", 16 } };
    long long ct = jint(a, "componentType", 0), cs = ct == 5120 || ct == 5121 ? 1 : ct == 5122 || ct == 5123 ? 2 : ct == 5125 || ct == 5126 ? 4 : 0;
    const cJSON *ty = cJSON_GetObjectItemCaseSensitive(a, "type");
    for (size_t i = 0; cJSON_IsString(ty) && i < sizeof k / sizeof k[0]; i++)
        if (!strcmp(ty->valuestring, k[i].t)) return cs * k[i].n;
    return 0;
}

/* Whether `count` elements of `elem` bytes at byte offset `off` with stride `stride` (0: packed) fit
 * in buffer view vi; its length into *vlen. */
static bool view_fits(const cJSON *views, long long vi, long long off, long long count, long long elem, long long stride) {
    const cJSON *v = vi >= 0 ? cJSON_GetArrayItem(views, (int)vi) : NULL;
    long long len = jint(v, "byteLength", -1), st = stride > 0 ? stride : elem;
    return v && len >= 0 && off >= 0 && count >= 0 && (count == 0 || off + st * (count - 1) + elem <= len);
}

/* The checks assimp 5.2 leaves out and then reads or allocates past (a forged byteLength, count or
 * offset): every buffer within its data, every view within its buffer, every accessor (and sparse
 * part) within its view. The first problem goes into gi->invalid. */
static void gltf_validate(const cJSON *root, gltf_info *gi) {
    const cJSON *bufs = cJSON_GetObjectItemCaseSensitive(root, "buffers"), *views = cJSON_GetObjectItemCaseSensitive(root, "bufferViews"), *e;
    char *why = gi->invalid;
    const size_t cap = sizeof gi->invalid;
    int i = 0;
    cJSON_ArrayForEach(e, bufs) {
        long long bl = jint(e, "byteLength", -1), have = buffer_bytes(e, gi);
        const cJSON *uri = cJSON_GetObjectItemCaseSensitive(e, "uri");
        bool data = cJSON_IsString(uri) && !strncmp(uri->valuestring, "data:", 5);
        if (!*why && (bl < 0 || (have >= 0 && bl > have) || (have < 0 && (!uri || data))))
            snprintf(why, cap, have < 0 && data ? "buffer %d: a data URI that is not base64"
                                                : "buffer %d: byteLength %lld, but its data holds %lld bytes", i, bl, have);
        i++;
    }
    i = 0;
    cJSON_ArrayForEach(e, cJSON_GetObjectItemCaseSensitive(root, "images")) {
        const cJSON *uri = cJSON_GetObjectItemCaseSensitive(e, "uri");
        if (!*why && cJSON_IsString(uri) && !strncmp(uri->valuestring, "data:", 5) && data_uri_bytes(uri->valuestring) < 0)
            snprintf(why, cap, "image %d: a data URI that is not base64", i);
        i++;
    }
    i = 0;
    cJSON_ArrayForEach(e, views) {
        long long b = jint(e, "buffer", -1), off = jint(e, "byteOffset", 0), len = jint(e, "byteLength", -1), st = jint(e, "byteStride", 0);
        const cJSON *buf = b >= 0 ? cJSON_GetArrayItem(bufs, (int)b) : NULL;
        if (!*why && (!buf || off < 0 || len < 0 || off + len > jint(buf, "byteLength", -1) || (st && (st < 4 || st > 252))))
            snprintf(why, cap, "bufferView %d: bytes %lld..%lld outside buffer %lld (or a bad stride)", i, off, off + len, b);
        i++;
    }
    i = 0;
    cJSON_ArrayForEach(e, cJSON_GetObjectItemCaseSensitive(root, "accessors")) {
        long long n = jint(e, "count", -1), el = element_bytes(e), vi = jint(e, "bufferView", -2);
        const cJSON *sp = cJSON_GetObjectItemCaseSensitive(e, "sparse");
        const cJSON *sv = vi >= 0 ? cJSON_GetArrayItem(views, (int)vi) : NULL;
        bool ok = n >= 1 && n <= ASSET_MAX_ELEMS && el > 0 &&
                  (vi == -2 ? n <= (1 << 24) : view_fits(views, vi, jint(e, "byteOffset", 0), n, el, jint(sv, "byteStride", 0)));
        if (ok && sp) {
            const cJSON *si = cJSON_GetObjectItemCaseSensitive(sp, "indices"), *sv2 = cJSON_GetObjectItemCaseSensitive(sp, "values");
            long long sn = jint(sp, "count", -1), ict = jint(si, "componentType", 0), isz = ict == 5121 ? 1 : ict == 5123 ? 2 : ict == 5125 ? 4 : 0;
            ok = sn >= 1 && sn <= n && isz > 0 && view_fits(views, jint(si, "bufferView", -1), jint(si, "byteOffset", 0), sn, isz, 0) &&
                 view_fits(views, jint(sv2, "bufferView", -1), jint(sv2, "byteOffset", 0), sn, el, 0);
        }
        if (!*why && !ok) snprintf(why, cap, "accessor %d: %lld elements of %lld bytes do not fit its data", i, n, el);
        i++;
    }
}

/* Every primitive's mode (0-6), its POSITION accessor and its indices' accessor (when it has them)
 * checked, and enough elements for its mode: assimp 5.2 makes count - 2 faces of a strip or fan and
 * count - 1 of a line strip in unsigned arithmetic (a primitive without positions has a count of 0),
 * and allocated 64 GB for such a fan. The first problem goes into gi->invalid. */
static void gltf_validate_prims(const cJSON *root, gltf_info *gi) {
    const cJSON *acc = cJSON_GetObjectItemCaseSensitive(root, "accessors"), *mesh, *p;
    int nacc = cJSON_GetArraySize(acc), mi = 0;
    cJSON_ArrayForEach(mesh, cJSON_GetObjectItemCaseSensitive(root, "meshes")) {
        int pi = 0;
        cJSON_ArrayForEach(p, cJSON_GetObjectItemCaseSensitive(mesh, "primitives")) {
            long long md = jint(p, "mode", 4), pos = jint(cJSON_GetObjectItemCaseSensitive(p, "attributes"), "POSITION", -1);
            long long ix = jint(p, "indices", -2);
            const cJSON *ea = pos >= 0 && pos < nacc ? cJSON_GetArrayItem(acc, (int)(ix >= 0 ? ix : pos)) : NULL;
            long long n = ix >= nacc || ix == -1 ? -1 : jint(ea, "count", -1), need = md == 3 ? 2 : md == 5 || md == 6 ? 3 : 1;
            if (!gi->invalid[0] && (md < 0 || md > 6 || !ea || n < need))
                snprintf(gi->invalid, sizeof gi->invalid, "mesh %d primitive %d: %s", mi, pi,
                         md < 0 || md > 6 ? "a mode outside 0..6" : !ea || n < 0 ? "no POSITION accessor (or a bad indices one)"
                                                                   : "fewer elements than its mode's first primitive needs");
            pi++;
        }
        mi++;
    }
}

/* Marks in used[] the meshes of node ni and its descendants (visited[] stops a cycle, and walk's
 * depth limit a chain). */
static void mark_meshes(const cJSON *nodes, int ni, unsigned char *used, int nmesh, unsigned char *visited, int nnode, int depth) {
    if (ni < 0 || ni >= nnode || visited[ni] || depth > 256) return;
    visited[ni] = 1;
    const cJSON *node = cJSON_GetArrayItem(nodes, ni), *mesh = cJSON_GetObjectItemCaseSensitive(node, "mesh"), *c;
    if (cJSON_IsNumber(mesh) && mesh->valueint >= 0 && mesh->valueint < nmesh) used[mesh->valueint] = 1;
    cJSON_ArrayForEach(c, cJSON_GetObjectItemCaseSensitive(node, "children"))
        if (cJSON_IsNumber(c)) mark_meshes(nodes, c->valueint, used, nmesh, visited, nnode, depth + 1);
}

/* Triangles of the meshes the default scene's nodes use, each mesh once (assimp imports those
 * meshes, once each, one aiMesh per primitive); -1 when the document has no such scene. */
static long long scene_triangles(const cJSON *root) {
    const cJSON *scenes = cJSON_GetObjectItemCaseSensitive(root, "scenes"), *si = cJSON_GetObjectItemCaseSensitive(root, "scene");
    const cJSON *sc = cJSON_GetArrayItem(scenes, cJSON_IsNumber(si) ? si->valueint : 0), *e, *p;
    const cJSON *nodes = cJSON_GetObjectItemCaseSensitive(root, "nodes"), *meshes = cJSON_GetObjectItemCaseSensitive(root, "meshes");
    const cJSON *acc = cJSON_GetObjectItemCaseSensitive(root, "accessors");
    int nmesh = cJSON_GetArraySize(meshes), nnode = cJSON_GetArraySize(nodes);
    if (!sc) return -1;
    unsigned char *used = calloc((size_t)nmesh + 1, 1), *visited = calloc((size_t)nnode + 1, 1);
    long long tri = -1;
    if (used && visited) {
        cJSON_ArrayForEach(e, cJSON_GetObjectItemCaseSensitive(sc, "nodes"))
            if (cJSON_IsNumber(e)) mark_meshes(nodes, e->valueint, used, nmesh, visited, nnode, 0);
        tri = 0;
        for (int m = 0; m < nmesh; m++)
            if (used[m]) cJSON_ArrayForEach(p, cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(meshes, m), "primitives"))
                tri += prim_triangles(p, acc);
    }
    free(used);
    free(visited);
    return tri;
}

/* Why prt ignores a glTF extension that changes the lobe ("" for one it takes or that needs no word). */
static const char *extension_note(const char *ext) {
    static const char *const k[][2] = {
        { "KHR_materials_clearcoat", "a clear-coat layer over the lobe; prt has one GGX lobe" },
        { "KHR_materials_sheen", "a sheen lobe; prt has one GGX lobe" },
        { "KHR_materials_transmission", "transmission; prt's surfaces are opaque" },
        { "KHR_materials_volume", "a volume; prt's surfaces are opaque" },
        { "KHR_materials_ior", "the index of refraction; F0 stays 0.04 for dielectrics" },
        { "KHR_materials_specular", "a specular strength and colour; F0 stays mix(0.04, baseColor, metallic)" },
        { "KHR_materials_iridescence", "thin-film iridescence; prt's Fresnel term is Schlick's" },
        { "KHR_materials_anisotropy", "anisotropy; prt's GGX is isotropic" },
        { "KHR_materials_pbrSpecularGlossiness", "the specular-glossiness model; the metallic-roughness values are used" },
        { "KHR_materials_unlit", "unlit shading; the surface is lit as metallic-roughness" },
        { "KHR_materials_emissive_strength", "emission; prt's surfaces do not emit" },
        { "KHR_texture_transform", "texture transforms; UVs are used as stored" },
    };
    for (size_t i = 0; i < sizeof k / sizeof k[0]; i++)
        if (!strcmp(ext, k[i][0])) return k[i][1];
    if (!strcmp(ext, "KHR_lights_punctual")) return "";
    return !strncmp(ext, "KHR_materials_", 14) ? "a material extension prt does not know" : "an extension prt does not read";
}

/* Reads the glTF's JSON text[len]: notes each ignored extension in s, counts its triangles and
 * validates it (gltf_validate). Text that does not parse as a JSON object is refused by the caller:
 * assimp would hand it to whichever of its readers takes it (its OBJ reader, unchecked). */
static void gltf_inspect(const char *name, const char *text, size_t len, prt_scene *s, gltf_info *gi) {
    gi->triangles = -1;
    cJSON *root = len <= ASSET_MAX_JSON ? cJSON_ParseWithLength(text, len) : NULL;
    gi->json_ok = cJSON_IsObject(root);
    if (!root) return;
    const cJSON *e;
    cJSON_ArrayForEach(e, cJSON_GetObjectItemCaseSensitive(root, "extensionsUsed")) {
        const char *why = cJSON_IsString(e) ? extension_note(e->valuestring) : "";
        if (*why) scene_note(s, "%s: %.60s ignored: %s", base_name(name), e->valuestring, why);
    }
    gi->triangles = scene_triangles(root);
    gltf_validate(root, gi);
    gltf_validate_prims(root, gi);
    const char *const arrays[2] = { "buffers", "images" };
    for (int a = 0; a < 2; a++)
        cJSON_ArrayForEach(e, cJSON_GetObjectItemCaseSensitive(root, arrays[a])) {
            const cJSON *uri = cJSON_GetObjectItemCaseSensitive(e, "uri");
            if (cJSON_IsString(uri) && strncmp(uri->valuestring, "data:", 5) && !gi->external[0])
                snprintf(gi->external, sizeof gi->external, "%.100s", uri->valuestring);
        }
    cJSON_Delete(root);
}

/* Reads the glTF file at path (size bytes) and inspects it (see gltf_inspect, gltf_json). */
static void gltf_inspect_file(const char *path, size_t size, prt_scene *s, gltf_info *gi) {
    gi->triangles = -1;
    gi->path = path;
    FILE *f = fopen(path, "rb");
    unsigned char *buf = f ? malloc(size) : NULL;
    if (buf && fread(buf, 1, size, f) == size) {
        size_t jl = 0;
        const char *js = gltf_json(buf, size, &jl, gi);
        if (js) gltf_inspect(path, js, jl, s, gi);
    }
    free(buf);
    if (f) fclose(f);
}

/* ---------------------------------------------------------------- OBJ */

/* The keyword of the line at p (end e): its first blank-separated word, skipping leading blanks. */
static size_t obj_keyword(const char **p, const char *e) {
    while (*p < e && (**p == ' ' || **p == '\t')) (*p)++;
    const char *k = *p;
    while (*p < e && **p != ' ' && **p != '\t') (*p)++;
    return (size_t)(*p - k);
}

/* Whether every index of a face, line or point statement (p..e: "1/2/3 -1//2 ...") names a v, vt or
 * vn that exists: 1..total, or -1..-(those read so far) (seen). */
static bool obj_indices_ok(const char *p, const char *e, const long long total[3], const long long seen[3]) {
    while (p < e) {
        while (p < e && (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\\')) p++;
        for (int part = 0; p < e && *p != ' ' && *p != '\t' && *p != '\r'; part++) {
            if (part > 2) return false;
            char *end;
            errno = 0;
            long long ix = *p == '/' ? 0 : strtoll(p, &end, 10);
            if (*p != '/') {
                if (end == p || end > e || errno || ix == 0 || ix > total[part] || (ix < 0 && -ix > seen[part])) return false;
                p = end;
            }
            if (p < e && *p == '/') p++;
            else if (p < e && *p != ' ' && *p != '\t' && *p != '\r') return false;
        }
    }
    return true;
}

/* Whether p..e holds between lo and hi numbers (strtod's syntax) and nothing else. */
static bool obj_numbers_ok(const char *p, const char *e, int lo, int hi) {
    int n = 0;
    while (p < e) {
        while (p < e && (*p == ' ' || *p == '\t' || *p == '\r')) p++;
        if (p >= e) break;
        char *end;
        strtod(p, &end);
        if (end == p || end > e || (end < e && *end != ' ' && *end != '\t' && *end != '\r')) return false;
        p = end;
        n++;
    }
    return n >= lo && n <= hi;
}

/* The statements the assimp path takes and how many numbers each vertex statement has: v 3-7
 * (with a colour), vt 1-3, vn 3, vp 1-3; face, line and point statements, o, g, s, usemtl, mtllib
 * and comments. Returns the kind (0 v, 1 vt, 2 vn, 3 vp, 4 f/l/p, 5 other known, 6 blank), -1 refused. */
static int obj_statement(const char *k, size_t kn, const char *p, const char *e) {
    static const char *const names[] = { "v", "vt", "vn", "vp" };
    static const int lo[] = { 3, 1, 3, 1 }, hi[] = { 7, 3, 3, 3 };
    if (kn == 0 || k[0] == '#') return 6;
    for (int i = 0; i < 4; i++)
        if (strlen(names[i]) == kn && !memcmp(k, names[i], kn)) return obj_numbers_ok(p, e, lo[i], hi[i]) ? i : -1;
    if (kn == 1 && (k[0] == 'f' || k[0] == 'l' || k[0] == 'p')) return 4;
    static const char *const other[] = { "o", "g", "s", "usemtl", "mtllib" };
    for (int i = 0; i < 5; i++)
        if (strlen(other[i]) == kn && !memcmp(k, other[i], kn)) return 5;
    return -1;
}

/* assimp 5.2's OBJ reader follows vt and vn indices without checking them (a read out of bounds) and
 * takes material statements (map_Ke) outside a material (a null dereference): every statement and
 * index of text[len] is checked first against what the assimp path takes. 0, or -1 with one line
 * naming the line. */
static int obj_check_text(const char *name, const char *text, size_t len, prt_error *err) {
    long long total[3] = { 0, 0, 0 }, seen[3] = { 0, 0, 0 };
    for (int pass = 0; pass < 2; pass++) {
        int line = 0;
        for (const char *p = text, *end = text + len; p < end; line++) {
            const char *nl = p;   /* a line ends at LF or CR (assimp's reader splits at either) */
            while (nl < end && *nl != '\n' && *nl != '\r') {
                if ((unsigned char)*nl < 32 && *nl != '\t')   /* a NUL or control byte: assimp's reader ends a line there too */
                    return prt_fail(err, "%s:%d: a control byte (0x%02x) in the text", name, line + 1, (unsigned char)*nl);
                nl++;
            }
            const char *e = nl;
            if (nl + 1 < end && nl[0] == '\r' && nl[1] == '\n') nl++;   /* CRLF: one line end */
            nl = nl < end ? nl : NULL;
            const char *hash = memchr(p, '#', (size_t)(e - p));
            size_t kn = obj_keyword(&p, hash ? hash : e);
            const char *k = p - kn;
            int which = obj_statement(k, kn, p, hash ? hash : e);
            if (which < 0) {
                char kw[24];
                size_t n = kn < sizeof kw - 1 ? kn : sizeof kw - 1;
                for (size_t i = 0; i < n; i++) kw[i] = k[i] > 32 && k[i] < 127 ? k[i] : '?';
                kw[n] = 0;
                return prt_fail(err, "%s:%d: a statement the OBJ + MTL reader does not take ('%s', or its numbers)", name,
                                line + 1, kw);
            }
            if (which < 3) (pass ? seen : total)[which]++;
            bool ref = which == 4;
            if (pass && ref && !obj_indices_ok(p, hash ? hash : e, total, seen))
                return prt_fail(err, "%s:%d: an index out of range (the file has %lld v, %lld vt, %lld vn)", name, line + 1,
                                total[0], total[1], total[2]);
            p = nl ? nl + 1 : end;
        }
    }
    return 0;
}

/* ---------------------------------------------------------------- PLY */

/* The bytes of PLY scalar type w (n bytes), 0 when it is none. */
static int ply_type(const char *w, size_t n) {
    static const struct { const char *t; int b; } k[] = { { "char", 1 }, { "uchar", 1 }, { "short", 2 }, { "ushort", 2 },
        { "int", 4 }, { "uint", 4 }, { "float", 4 }, { "double", 8 }, { "int8", 1 }, { "uint8", 1 }, { "int16", 2 },
        { "uint16", 2 }, { "int32", 4 }, { "uint32", 4 }, { "float32", 4 }, { "float64", 8 } };
    for (size_t i = 0; i < sizeof k / sizeof k[0]; i++)
        if (strlen(k[i].t) == n && !memcmp(k[i].t, w, n)) return k[i].b;
    return 0;
}

/* A PLY header's layout: the format and each element's count and properties' byte sizes. */
#define PLY_MAX_ELEMENTS 16
#define PLY_MAX_PROPS 32
typedef struct ply_layout {
    int format;                                   /* 0 ascii, 1 little-endian, 2 big-endian */
    int nel;
    bool vertex;                                  /* an element named vertex */
    int vxyz;                                     /* its x, y, z properties (bits 0, 1, 2) */
    bool in_vertex;                               /* the element being declared is the vertex one */
    char name[PLY_MAX_ELEMENTS][32];              /* element names (unique) */
    long long count[PLY_MAX_ELEMENTS];
    int nprop[PLY_MAX_ELEMENTS];
    uint8_t csize[PLY_MAX_ELEMENTS][PLY_MAX_PROPS];   /* a list's count type (0: a scalar property) */
    uint8_t size[PLY_MAX_ELEMENTS][PLY_MAX_PROPS];    /* the scalar's, or the list items' */
} ply_layout;

/* The next blank-separated token of an ASCII body's line at *p (NUL-terminated text) as a number;
 * false at the line's end or on a token that is not one (a list count: a whole number up to 2^20). */
static bool ply_token(const char **p, bool count, double *x) {
    const char *q = *p;
    while (*q == ' ' || *q == '\t' || *q == '\r') q++;
    if (*q == '\n' || !*q) return false;
    char *end;
    *x = strtod(q, &end);
    if (end == q || (*end && *end != ' ' && *end != '\t' && *end != '\r' && *end != '\n')) return false;
    *p = end;
    return !count || (*x >= 0 && *x <= (1 << 20) && *x == floor(*x));
}

/* Whether an ASCII body (NUL-terminated text at b) holds every element the layout declares, one
 * instance a line of numbers and nothing more (assimp 5.2 reads it line by line, a shifted line's
 * number as a list count: it allocated 19 GB for one, and its post-processing crashed on others). */
static bool ply_ascii_ok(const ply_layout *y, const char *b) {
    for (int e = 0; e < y->nel; e++)
        for (long long i = 0; i < y->count[e]; i++) {
            for (int p = 0; p < y->nprop[e]; p++) {
                double x, item;
                if (!ply_token(&b, y->csize[e][p] != 0, &x)) return false;
                const long long items = y->csize[e][p] ? (long long)x : 0;   /* a list's count: at most 2^20 */
                for (long long k = 0; k < items; k++)
                    if (!ply_token(&b, false, &item)) return false;
            }
            while (*b == ' ' || *b == '\t' || *b == '\r') b++;
            if (*b != '\n' && *b) return false;   /* more on the line than the instance */
            if (*b) b++;
        }
    return true;
}

/* Whether a binary body b[n] holds every element the layout declares (each list's count read and
 * its items skipped): assimp 5.2's binary reader reads past a body shorter than its header says. */
static bool ply_body_ok(const ply_layout *y, const unsigned char *b, size_t n) {
    size_t at = 0;
    for (int e = 0; e < y->nel; e++)
        for (long long i = 0; i < y->count[e]; i++)
            for (int p = 0; p < y->nprop[e]; p++) {
                size_t cs = y->csize[e][p], k = 1;
                if (cs) {   /* a list: its count, then that many items */
                    if (n - at < cs) return false;
                    uint64_t c = 0;
                    for (size_t j = 0; j < cs; j++) c |= (uint64_t)b[at + (y->format == 1 ? j : cs - 1 - j)] << (8 * j);
                    if (c > (1u << 20)) return false;
                    at += cs;
                    k = (size_t)c;
                }
                if ((n - at) / y->size[e][p] < k) return false;
                at += k * y->size[e][p];
            }
    return true;
}

/* The words of line p..e (at most 6) into w[] / wn[]; returns their count (7: too many). */
static int ply_words(const char *p, const char *e, const char *w[6], size_t wn[6]) {
    int n = 0;
    while (p < e) {
        while (p < e && (*p == ' ' || *p == '\t' || *p == '\r')) p++;
        if (p >= e) break;
        if (n == 6) return 7;
        w[n] = p;
        while (p < e && *p != ' ' && *p != '\t' && *p != '\r') p++;
        wn[n] = (size_t)(p - w[n]);
        n++;
    }
    return n;
}

/* One header line (p..e) is well formed (printable ASCII, a known keyword with its fields) and
 * goes into the layout y. */
static bool ply_line_ok(const char *p, const char *e, ply_layout *y) {
    for (const char *q = p; q < e; q++)   /* a CR only ends the line (assimp breaks lines at it) */
        if ((*q < 32 && *q != '\t' && !(*q == '\r' && q + 1 == e)) || *q > 126) return false;
    const char *w[6];
    size_t n[6];
    int k = ply_words(p, e, w, n);
    if (k == 0) return true;
#define PLY_IS(i, s) (n[i] == strlen(s) && !memcmp(w[i], s, n[i]))
    if (PLY_IS(0, "comment") || PLY_IS(0, "obj_info")) return true;
    if (PLY_IS(0, "format")) {   /* once, before any element */
        if (y->format >= 0 || y->nel > 0) return false;
        y->format = k == 3 && PLY_IS(2, "1.0") ? (PLY_IS(1, "ascii") ? 0 : PLY_IS(1, "binary_little_endian") ? 1 : PLY_IS(1, "binary_big_endian") ? 2 : -1) : -1;
        return y->format >= 0;
    }
    if (PLY_IS(0, "element")) {
        if (k != 3 || n[2] > 10 || n[2] == 0 || y->nel >= PLY_MAX_ELEMENTS) return false;
        for (size_t i = 0; i < n[2]; i++)
            if (w[2][i] < '0' || w[2][i] > '9') return false;
        if (y->format < 0 || n[1] >= sizeof y->name[0]) return false;
        if (!PLY_IS(1, "vertex") && !PLY_IS(1, "face") && !PLY_IS(1, "edge")) return false;   /* assimp's others misread */
        for (int i = 0; i < y->nel; i++)   /* one element of a name: assimp frees a repeated one twice */
            if (strlen(y->name[i]) == n[1] && !memcmp(y->name[i], w[1], n[1])) return false;
        memcpy(y->name[y->nel], w[1], n[1]);
        y->name[y->nel][n[1]] = 0;
        y->in_vertex = PLY_IS(1, "vertex");
        y->vertex |= y->in_vertex;
        y->count[y->nel++] = strtoll(w[2], NULL, 10);
        return true;
    }
    if (PLY_IS(0, "property")) {
        int el = y->nel - 1, np = el >= 0 ? y->nprop[el] : PLY_MAX_PROPS;
        if (np >= PLY_MAX_PROPS) return false;
        bool list = k == 5 && PLY_IS(1, "list");
        if (list && w[2][0] != 'u') return false;   /* a list's count is unsigned: assimp widens a signed one's -1 */
        int cs = list ? ply_type(w[2], n[2]) : 0, sz = list ? ply_type(w[3], n[3]) : k == 3 ? ply_type(w[1], n[1]) : 0;
        if (!sz || (list && !cs)) return false;
        y->csize[el][np] = (uint8_t)cs;
        y->size[el][np] = (uint8_t)sz;
        if (y->in_vertex && !list && n[2] == 1 && w[2][0] >= 'x' && w[2][0] <= 'z') y->vxyz |= 1 << (w[2][0] - 'x');
        y->nprop[el]++;
        return true;
    }
#undef PLY_IS
    return false;
}

/* assimp 5.2's PLY reader loops forever on some malformed headers (NUL bytes in a keyword) and
 * reads past a binary body shorter than its header says: the header (up to end_header, within the
 * first 64 KB of buf[len], len the whole file) is checked first, with a vertex element (and only
 * vertex, face and edge elements: assimp 5.2 allocated 2 GB for a 2-instance unknown one), no element
 * counting more than the file's bytes, and a body that holds what the header declares (buf[len] is
 * 0: an ASCII body is read as text). 0, or -1 with one line. */
static int ply_check(const char *name, const char *buf, size_t len, prt_error *err) {
    size_t lim = len < (64 << 10) ? len : (64 << 10);
    if (lim < 4 || memcmp(buf, "ply", 3) || (buf[3] != '\n' && buf[3] != '\r')) return prt_fail(err, "%s: not a PLY file (no 'ply' line)", name);
    ply_layout y = { .format = -1 };
    int line = 1;
    for (const char *p = buf + 4, *end = buf + lim; p < end; line++) {
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        if (!nl) break;
        if (nl - p >= 10 && !memcmp(p, "end_header", 10) && (nl - p == 10 || (nl - p == 11 && p[10] == '\r'))) {
            if (y.format < 0 || !y.vertex) return prt_fail(err, "%s: its header has no format or no vertex element", name);
            for (int e = 0; e < y.nel; e++)
                if ((unsigned long long)y.count[e] > len) return prt_fail(err, "%s: an element count larger than the file", name);
            if (y.vxyz != 7) return prt_fail(err, "%s: its vertex element has no x, y and z", name);
            if (y.format > 0 && !ply_body_ok(&y, (const unsigned char *)nl + 1, (size_t)(buf + len - nl - 1)))
                return prt_fail(err, "%s: its binary body is shorter than its header says", name);
            if (y.format == 0 && !ply_ascii_ok(&y, nl + 1))
                return prt_fail(err, "%s: its ASCII body does not hold the numbers its header declares", name);
            return 0;
        }
        if (!ply_line_ok(p, nl, &y)) return prt_fail(err, "%s:%d: a malformed PLY header line", name, line + 1);
        p = nl + 1;
    }
    return prt_fail(err, "%s: no end_header in its first %zu bytes", name, lim);
}

/* A text checker (obj_check_text, ply_check): reads text[len], NUL-terminated at len. */
typedef int (*text_check_fn)(const char *name, const char *text, size_t len, prt_error *err);

/* check on a NUL-terminated copy of text[len] (strtod and friends read up to a terminator). */
static int check_memory(text_check_fn check, const char *name, const char *text, size_t len, prt_error *err) {
    char *copy = malloc(len + 1);
    if (!copy) return prt_fail(err, "%s: out of memory", name);
    memcpy(copy, text, len);
    copy[len] = 0;
    int rc = check(name, copy, len, err);
    free(copy);
    return rc;
}

/* check on the whole file at path, read NUL-terminated. */
static int check_file(text_check_fn check, const char *path, prt_error *err) {
    size_t n = 0;
    FILE *f = fopen(path, "rb");
    char *buf = NULL;
    long sz = f && !fseek(f, 0, SEEK_END) ? ftell(f) : -1;
    if (sz >= 0 && !fseek(f, 0, SEEK_SET) && (buf = malloc((size_t)sz + 1))) n = fread(buf, 1, (size_t)sz, f);
    if (f) fclose(f);
    if (!buf) return prt_fail(err, "%s: cannot read", path);
    buf[n] = 0;
    int rc = check(path, buf, n, err);
    free(buf);
    return rc;
}

/* ---------------------------------------------------------------- transforms */

/* Row-major 4x4 of an aiMatrix4x4 (column vectors: p' = M p, translation in the last column). */
static void mat_from_ai(double M[16], const struct aiMatrix4x4 *a) {
    const double v[16] = { a->a1, a->a2, a->a3, a->a4, a->b1, a->b2, a->b3, a->b4,
                           a->c1, a->c2, a->c3, a->c4, a->d1, a->d2, a->d3, a->d4 };
    memcpy(M, v, sizeof v);
}

/* C = A B (4x4 row-major; C may alias neither). */
static void mat_mul(double C[16], const double A[16], const double B[16]) {
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            double x = 0;
            for (int k = 0; k < 4; k++) x += A[4 * i + k] * B[4 * k + j];
            C[4 * i + j] = x;
        }
}

/* out = M p (w = 1) or, for a direction (w = 0), M's 3x3 times p. */
static void mat_apply(const double M[16], const float p[3], double w, float out[3]) {
    double r[3];
    for (int i = 0; i < 3; i++) r[i] = M[4 * i] * p[0] + M[4 * i + 1] * p[1] + M[4 * i + 2] * p[2] + M[4 * i + 3] * w;
    for (int i = 0; i < 3; i++) out[i] = (float)r[i];
}

/* The cofactor matrix of M's 3x3 (det times its inverse transpose: what carries normals, up to
 * the determinant's sign and size, which the caller's normalization and sign take out); returns det. */
static double mat_cofactor(const double M[16], double C[9]) {
    const double a = M[0], b = M[1], c = M[2], d = M[4], e = M[5], f = M[6], g = M[8], h = M[9], i = M[10];
    const double v[9] = { e * i - f * h, f * g - d * i, d * h - e * g, c * h - b * i, a * i - c * g,
                          b * g - a * h, b * f - c * e, c * d - a * f, a * e - b * d };
    memcpy(C, v, sizeof v);
    return a * v[0] + b * v[1] + c * v[2];
}

static bool mat_finite(const double M[16]) {
    for (int i = 0; i < 16; i++)
        if (!isfinite(M[i])) return false;
    return true;
}

/* The global transform of the node named name (depth-first from node under parent P), or false. */
static bool node_find(const struct aiNode *node, const double P[16], const char *name, double out[16], int depth) {
    double L[16], G[16];
    mat_from_ai(L, &node->mTransformation);
    mat_mul(G, P, L);
    if (!strcmp(node->mName.data, name)) {
        memcpy(out, G, sizeof G);
        return true;
    }
    for (unsigned c = 0; depth < 256 && c < node->mNumChildren; c++)
        if (node_find(node->mChildren[c], G, name, out, depth + 1)) return true;
    return false;
}

/* ---------------------------------------------------------------- materials */

/* Reads an RGB colour key (the first three of its floats); false when absent. */
static bool mat_rgb(const struct aiMaterial *m, const char *key, float rgb[3]) {
    struct aiColor4D c;
    if (aiGetMaterialColor(m, key, 0, 0, &c) != aiReturn_SUCCESS) return false;
    rgb[0] = c.r, rgb[1] = c.g, rgb[2] = c.b;
    return true;
}

static bool mat_float(const struct aiMaterial *m, const char *key, float *x) {
    ai_real v;
    unsigned int n = 1;
    if (aiGetMaterialFloatArray(m, key, 0, 0, &v, &n) != aiReturn_SUCCESS || n < 1) return false;
    *x = (float)v;
    return true;
}

/* The spec and plan note of glTF material m (asset.h: metallic-roughness onto GGX); returns its metallic. */
static float spec_gltf(const struct aiMaterial *m, const char *mname, char *spec, size_t cap, char *from, size_t fcap,
                      const char *file) {
    float base[3] = { 1, 1, 1 }, metal = 1, rough = 1;   /* glTF 2.0's defaults */
    if (!mat_rgb(m, "$clr.base", base)) mat_rgb(m, "$clr.diffuse", base);
    mat_float(m, "$mat.metallicFactor", &metal);
    mat_float(m, "$mat.roughnessFactor", &rough);
    float kd[3], ks[3], alpha = rough * rough;
    for (int c = 0; c < 3; c++) {
        kd[c] = base[c] * (1 - metal);
        ks[c] = 0.04f * (1 - metal) + base[c] * metal;
    }
    if (!(alpha >= ASSET_ALPHA_MIN)) alpha = ASSET_ALPHA_MIN;   /* also a NaN: brdf_parse refuses it anyway */
    snprintf(spec, cap, "ggx:kd=%.9g,%.9g,%.9g;ks=%.9g,%.9g,%.9g;alpha=%.9g", kd[0], kd[1], kd[2], ks[0], ks[1], ks[2], alpha);
    snprintf(from, fcap, "%.60s material '%.40s' (glTF metallic-roughness: baseColor %.3g,%.3g,%.3g, metallic %.3g, "
             "roughness %.3g)", file, mname, base[0], base[1], base[2], metal, rough);
    return metal;
}

/* The spec and plan note of MTL material m (asset.h: Kd, Ks, Ns onto Phong). */
static void spec_mtl(const struct aiMaterial *m, const char *mname, char *spec, size_t cap, char *from, size_t fcap,
                     const char *file) {
    float kd[3] = { 0, 0, 0 }, ks[3] = { 0, 0, 0 }, ns = 0;
    mat_rgb(m, "$clr.diffuse", kd);
    mat_rgb(m, "$clr.specular", ks);
    mat_float(m, "$mat.shininess", &ns);
    if (ks[0] == 0 && ks[1] == 0 && ks[2] == 0) snprintf(spec, cap, "lambert:kd=%.9g,%.9g,%.9g", kd[0], kd[1], kd[2]);
    else snprintf(spec, cap, "phong:kd=%.9g,%.9g,%.9g;ks=%.9g,%.9g,%.9g;n=%.9g", kd[0], kd[1], kd[2], ks[0], ks[1], ks[2], ns);
    snprintf(from, fcap, "%.60s material '%.40s' (MTL Kd %.3g,%.3g,%.3g, Ks %.3g,%.3g,%.3g, Ns %.3g)", file, mname, kd[0],
             kd[1], kd[2], ks[0], ks[1], ks[2], ns);
}

/* assimp's stand-in for faces without a material (an OBJ face before any usemtl, every PLY face). */
static bool is_default_material(const struct aiMaterial *m, const char *mname, asset_format fmt) {
    return fmt == FMT_PLY || (fmt == FMT_OBJ && !strcmp(mname, "DefaultMaterial"));
}

/* An embedded texture (a .glb's or data URI's image: compressed bytes, or raw BGRA texels) into t. */
static int embedded_texture(loader *L, const struct aiTexture *at, const char *name, scene_texture *t) {
    prt_error e2;
    if (at->mHeight == 0) {   /* a PNG or JPEG file's bytes: OpenImageIO decodes them */
        char mem[200];
        snprintf(mem, sizeof mem, "%.128s.%.8s", name, at->achFormatHint[0] ? at->achFormatHint : "png");
        prt_image im;
        if (image_read_memory(mem, at->pcData, at->mWidth, &im, &e2))
            return prt_fail(L->err, "%s: texture '%s': %s", L->name, name, e2.msg);
        int rc = texture_from_image(t, name, &im, &e2);
        image_free(&im);
        return rc ? prt_fail(L->err, "%s: %s", L->name, e2.msg) : 0;
    }
    if (at->mWidth > TEXTURE_MAX_SIDE || at->mHeight > TEXTURE_MAX_SIDE)
        return prt_fail(L->err, "%s: texture '%s': %ux%u too large", L->name, name, at->mWidth, at->mHeight);
    size_t n = (size_t)at->mWidth * at->mHeight;
    uint8_t *b = malloc(3 * n);
    if (!b) return prt_fail(L->err, "%s: out of memory", L->name);
    for (size_t i = 0; i < n; i++) b[3 * i] = at->pcData[i].r, b[3 * i + 1] = at->pcData[i].g, b[3 * i + 2] = at->pcData[i].b;
    int rc = texture_from_srgb(t, name, (int)at->mWidth, (int)at->mHeight, b, &e2);
    free(b);
    return rc ? prt_fail(L->err, "%s: %s", L->name, e2.msg) : 0;
}

/* An external texture file (relative to the model's folder) into t. */
static int file_texture(loader *L, const char *ref, scene_texture *t) {
    if (L->from_memory) return prt_fail(L->err, "%s: names the texture file '%.100s' (bytes in memory have no folder)", L->name, ref);
    char full[4096];
    const char *slash = strrchr(L->name, '/');
    if (ref[0] == '/' || !slash) snprintf(full, sizeof full, "%s", ref);
    else snprintf(full, sizeof full, "%.*s/%s", (int)(slash - L->name), L->name, ref);
    prt_image im;
    prt_error e2;
    if (image_read(full, &im, &e2)) return prt_fail(L->err, "%s: texture: %s", L->name, e2.msg);
    int rc = texture_from_image(t, ref, &im, &e2);
    image_free(&im);
    return rc ? prt_fail(L->err, "%s: %s", L->name, e2.msg) : 0;
}

/* The base-colour (glTF) or map_Kd (MTL) texture of material m in the scene, made once per
 * reference; its UV channel into *uvch. Returns its index, -1 when m has none, -2 with L->err. */
static int texture_of(loader *L, const struct aiMaterial *m, unsigned *uvch) {
    struct aiString path = { 0 };
    unsigned uvi = 0;
    if (aiGetMaterialTexture(m, aiTextureType_BASE_COLOR, 0, &path, NULL, &uvi, NULL, NULL, NULL, NULL) != aiReturn_SUCCESS &&
        aiGetMaterialTexture(m, aiTextureType_DIFFUSE, 0, &path, NULL, &uvi, NULL, NULL, NULL, NULL) != aiReturn_SUCCESS)
        return -1;
    if (!path.data[0]) return -1;
    *uvch = uvi;
    prt_scene *s = L->s;
    char name[128];
    long emb = -1;
    if (path.data[0] == '*') {
        char *end;
        emb = strtol(path.data + 1, &end, 10);
        if (*end || emb < 0 || emb >= (long)L->ai->mNumTextures)
            return prt_fail(L->err, "%s: a material names embedded texture '%.20s' of %u", L->name, path.data, L->ai->mNumTextures), -2;
        snprintf(name, sizeof name, "%.100s image %ld", base_name(L->name), emb);
    } else snprintf(name, sizeof name, "%.127s", path.data);
    for (int t = 0; t < s->ntextures; t++)
        if (!strcmp(s->textures[t].name, name)) return t;
    if (s->ntextures >= SCENE_MAX_TEXTURES) return prt_fail(L->err, "%s: more than %d textures", L->name, SCENE_MAX_TEXTURES), -2;
    scene_texture *t = &s->textures[s->ntextures];
    static const uint8_t white[3] = { 255, 255, 255 };
    prt_error e2;
    int rc = L->desc && L->desc->no_texture_pixels ? (texture_from_srgb(t, name, 1, 1, white, &e2) ? prt_fail(L->err, "%s", e2.msg) : 0)
             : emb >= 0 ? embedded_texture(L, L->ai->mTextures[emb], name, t) : file_texture(L, path.data, t);
    if (rc) return -2;
    if (emb < 0) snprintf(t->name, sizeof t->name, "%.127s", name);
    return s->ntextures++;
}

/* Whether material m names a base-colour (or diffuse) texture. */
static bool has_base_texture(const struct aiMaterial *m) {
    struct aiString path = { 0 };
    return (aiGetMaterialTexture(m, aiTextureType_BASE_COLOR, 0, &path, NULL, NULL, NULL, NULL, NULL, NULL) == aiReturn_SUCCESS ||
            aiGetMaterialTexture(m, aiTextureType_DIFFUSE, 0, &path, NULL, NULL, NULL, NULL, NULL, NULL) == aiReturn_SUCCESS) &&
           path.data[0];
}

/* The scene material of the file's material mi (made on first use); -1 with L->err. */
static int material_of(loader *L, unsigned mi) {
    if (mi >= L->ai->mNumMaterials) return prt_fail(L->err, "%s: a mesh uses material %u of %u", L->name, mi, L->ai->mNumMaterials);
    if (L->mat_index[mi] >= 0) return L->mat_index[mi];
    const struct aiMaterial *m = L->ai->mMaterials[mi];
    struct aiString nm = { 0 };
    char mname[64] = "", spec[256], from[512], file[64];
    float metal = 0;
    if (aiGetMaterialString(m, "?mat.name", 0, 0, &nm) == aiReturn_SUCCESS) snprintf(mname, sizeof mname, "%.63s", nm.data);
    snprintf(file, sizeof file, "%.63s", base_name(L->name));
    const asset_desc *d = L->desc;
    if (d && d->material) {
        snprintf(spec, sizeof spec, "%.255s", d->material);
        snprintf(from, sizeof from, "%.200s", d->material_from ? d->material_from : "--material");
    } else if (is_default_material(m, mname, L->fmt)) {
        snprintf(spec, sizeof spec, "%.255s", d && d->fallback ? d->fallback : ASSET_DEFAULT_MATERIAL);
        snprintf(from, sizeof from, "default (%.60s gives %s no material)", file, L->fmt == FMT_PLY ? "a PLY" : "these faces");
    } else if (L->fmt == FMT_GLTF) metal = spec_gltf(m, mname, spec, sizeof spec, from, sizeof from, file);
    else spec_mtl(m, mname, spec, sizeof spec, from, sizeof from, file);
    /* A texture scales kd only (docs/design/assets.md): a metal has none, so its texture is left out */
    bool metal_tex = !(d && d->material) && metal >= 1 && has_base_texture(m);
    if (metal_tex)
        scene_note(L->s, "%s: material '%s': its base-colour texture is not used (metallic 1 leaves no diffuse term; "
                   "prt's textures scale kd, F0 takes the base-colour factor)", file, mname);
    int tex = (d && d->material) || metal_tex ? -1 : texture_of(L, m, &L->mat_uv[mi]);
    if (tex == -2) return -1;
    if (tex >= 0) {   /* the SVD path cannot split kd from the lobe: there it scales the whole BRDF */
        size_t at = strlen(from);
        snprintf(from + at, sizeof from - at, "; texture '%.60s' multiplies kd%s", L->s->textures[tex].name,
                 strncmp(spec, "lambert", 7) ? " (on the SVD path: the whole BRDF)" : "");
        L->textured = true;
    }
    prt_error e2;
    int i = scene_material_textured(L->s, spec, from, tex, &e2);
    if (i < 0) return prt_fail(L->err, "%s: material '%s': %s", L->name, mname, e2.msg);
    return L->mat_index[mi] = i;
}

/* ---------------------------------------------------------------- meshes */

/* Room for nv more vertices and nt more triangles in out->mesh (and the normal flags). */
static int reserve(loader *L, size_t nv, size_t nt) {
    prt_mesh *m = &L->out->mesh;
    size_t v = (size_t)m->nverts + nv, t = (size_t)m->ntris + nt;
    if (v > ASSET_MAX_ELEMS || t > ASSET_MAX_ELEMS)
        return prt_fail(L->err, "%s: too large (more than %d vertices or triangles)", L->name, ASSET_MAX_ELEMS);
    if (v > L->cap_v) {
        size_t c = v > 2 * L->cap_v ? v : 2 * L->cap_v;
        float *p = realloc(m->pos, 3 * c * sizeof *p);
        if (p) m->pos = p;
        float *n = p ? realloc(m->nrm, 3 * c * sizeof *n) : NULL;
        if (n) m->nrm = n;
        uint16_t *mt = n ? realloc(m->mat, c * sizeof *mt) : NULL;
        if (mt) m->mat = mt;
        float *uv = mt ? realloc(m->uv, 2 * c * sizeof *uv) : NULL;
        if (uv) m->uv = uv;
        unsigned char *b = uv ? realloc(L->bad_normal, c) : NULL;
        if (!b) return prt_fail(L->err, "%s: out of memory", L->name);
        L->bad_normal = b;
        L->cap_v = c;
    }
    if (t > L->cap_t) {
        size_t c = t > 2 * L->cap_t ? t : 2 * L->cap_t;
        uint32_t *tr = realloc(m->tris, 3 * c * sizeof *tr);
        if (!tr) return prt_fail(L->err, "%s: out of memory", L->name);
        m->tris = tr;
        L->cap_t = c;
    }
    return 0;
}

/* Copies the vertices of am into out->mesh under transform M (cofactor C, determinant det):
 * positions, unit normals (flagged bad where absent or zero), the material. -1 on a non-finite value. */
static int put_vertices(loader *L, const struct aiMesh *am, const double M[16], const double C[9], double det, int mat) {
    prt_mesh *m = &L->out->mesh;
    const float sgn = det < 0 ? -1.f : 1.f;
    for (unsigned i = 0; i < am->mNumVertices; i++) {
        size_t v = (size_t)m->nverts + i;
        const float p[3] = { am->mVertices[i].x, am->mVertices[i].y, am->mVertices[i].z };
        float *q = m->pos + 3 * v, *n = m->nrm + 3 * v;
        mat_apply(M, p, 1, q);
        if (!isfinite(q[0]) || !isfinite(q[1]) || !isfinite(q[2]))
            return prt_fail(L->err, "%s: mesh '%.60s' vertex %u: non-finite coordinate (%g, %g, %g)", L->name, am->mName.data, i,
                            (double)p[0], (double)p[1], (double)p[2]);
        m->mat[v] = (uint16_t)mat;
        const struct aiVector3D *tc = am->mTextureCoords[L->mat_uv[am->mMaterialIndex] < AI_MAX_NUMBER_OF_TEXTURECOORDS ?
                                                         L->mat_uv[am->mMaterialIndex] : 0];
        m->uv[2 * v] = tc ? tc[i].x : 0;
        m->uv[2 * v + 1] = tc ? tc[i].y : 0;
        if (!isfinite(m->uv[2 * v]) || !isfinite(m->uv[2 * v + 1]))
            return prt_fail(L->err, "%s: mesh '%.60s' vertex %u: non-finite texture coordinate", L->name, am->mName.data, i);
        L->bad_normal[v] = 1;
        if (!am->mNormals) continue;
        const double a[3] = { am->mNormals[i].x, am->mNormals[i].y, am->mNormals[i].z };
        if (!isfinite(a[0]) || !isfinite(a[1]) || !isfinite(a[2]))
            return prt_fail(L->err, "%s: mesh '%.60s' vertex %u: non-finite normal", L->name, am->mName.data, i);
        double r[3], len = 0;
        for (int k = 0; k < 3; k++) r[k] = sgn * (C[3 * k] * a[0] + C[3 * k + 1] * a[1] + C[3 * k + 2] * a[2]), len += r[k] * r[k];
        len = sqrt(len);
        if (!(len > 1e-30) || !isfinite(len)) continue;
        for (int k = 0; k < 3; k++) n[k] = (float)(r[k] / len);
        L->bad_normal[v] = 0;
    }
    return 0;
}

/* Appends one instance of mesh am under global transform M. Meshes without triangles (points,
 * lines) are skipped and counted; bones and morph targets are counted (the rest pose is taken). */
static int put_mesh(loader *L, const struct aiMesh *am, const double M[16]) {
    if (!(am->mPrimitiveTypes & (aiPrimitiveType_TRIANGLE | aiPrimitiveType_POLYGON)) || am->mNumFaces == 0) {
        L->skipped_prims++;
        return 0;
    }
    size_t ntri = 0;   /* a polygon of n corners fans into n - 2 triangles (mesh.c's rule for OBJ faces) */
    for (unsigned f = 0; f < am->mNumFaces; f++) ntri += am->mFaces[f].mNumIndices >= 3 ? am->mFaces[f].mNumIndices - 2 : 0;
    if (ntri == 0) {   /* faces of fewer than 3 corners only */
        L->skipped_prims++;
        return 0;
    }
    L->skinned += am->mNumBones > 0;
    L->morphed += am->mNumAnimMeshes > 0;
    int mat = material_of(L, am->mMaterialIndex);
    if (mat < 0 || reserve(L, am->mNumVertices, ntri)) return -1;
    double C[9], det = mat_cofactor(M, C);
    if (put_vertices(L, am, M, C, det, mat)) return -1;
    prt_mesh *m = &L->out->mesh;
    uint32_t base = (uint32_t)m->nverts, *t = m->tris + 3 * (size_t)m->ntris;
    size_t nt = 0;
    for (unsigned f = 0; f < am->mNumFaces; f++) {
        const struct aiFace *fc = &am->mFaces[f];
        for (unsigned i = 0; i < fc->mNumIndices; i++)
            if (fc->mIndices[i] >= am->mNumVertices)
                return prt_fail(L->err, "%s: mesh '%.60s' face %u: index %u out of range (%u vertices)", L->name,
                                am->mName.data, f, fc->mIndices[i], am->mNumVertices);
        for (unsigned i = 1; i + 1 < fc->mNumIndices; i++, nt++) {   /* a stray point or line: none */
            const unsigned c[3] = { fc->mIndices[0], fc->mIndices[i], fc->mIndices[i + 1] };
            for (int k = 0; k < 3; k++) t[3 * nt + k] = base + c[det < 0 ? 2 - k : k];
        }
    }
    m->nverts += (int)am->mNumVertices;
    m->ntris += (int)nt;
    L->out->stats.faces += (int)nt;
    return 0;
}

/* Every mesh instance under node (parent transform P), depth first. */
static int walk(loader *L, const struct aiNode *node, const double P[16], int depth) {
    if (depth > 256) return prt_fail(L->err, "%s: the node tree is deeper than 256 (a cycle?)", L->name);
    double Lm[16], G[16];
    mat_from_ai(Lm, &node->mTransformation);
    mat_mul(G, P, Lm);
    if (!mat_finite(G)) return prt_fail(L->err, "%s: node '%.60s': non-finite transform", L->name, node->mName.data);
    for (unsigned i = 0; i < node->mNumMeshes; i++) {
        unsigned mi = node->mMeshes[i];
        if (mi >= L->ai->mNumMeshes) return prt_fail(L->err, "%s: node '%.60s' names mesh %u of %u", L->name, node->mName.data, mi, L->ai->mNumMeshes);
        if (put_mesh(L, L->ai->mMeshes[mi], G)) return -1;
    }
    for (unsigned c = 0; c < node->mNumChildren; c++)
        if (walk(L, node->mChildren[c], G, depth + 1)) return -1;
    return 0;
}

/* Twice the area of triangle abc (double). */
static double area2(const float *a, const float *b, const float *c) {
    double e1[3], e2[3], n[3];
    for (int k = 0; k < 3; k++) e1[k] = (double)b[k] - a[k], e2[k] = (double)c[k] - a[k];
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    return sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

/* Drops degenerate triangles (mesh.c's rule) and the vertices no triangle uses, keeping order. */
static int drop_unused(loader *L) {
    prt_mesh *m = &L->out->mesh;
    float lo[3], hi[3];
    mesh_bounds(m, lo, hi);
    double d2 = 0;
    for (int k = 0; k < 3; k++) d2 += ((double)hi[k] - lo[k]) * ((double)hi[k] - lo[k]);
    size_t nt = 0;
    for (size_t t = 0; t < (size_t)m->ntris; t++) {
        const uint32_t *x = m->tris + 3 * t;
        if (x[0] == x[1] || x[1] == x[2] || x[0] == x[2] ||
            area2(m->pos + 3 * (size_t)x[0], m->pos + 3 * (size_t)x[1], m->pos + 3 * (size_t)x[2]) <= ASSET_DEGENERATE_REL * d2) {
            L->out->stats.degenerate++;
            continue;
        }
        memmove(m->tris + 3 * nt, x, 3 * sizeof *x);
        nt++;
    }
    if (nt == 0) return prt_fail(L->err, "%s: no triangles%s", L->name, m->ntris ? " left (all are degenerate)" : "");
    m->ntris = (int)nt;
    uint32_t *map = malloc((size_t)m->nverts * sizeof *map);
    if (!map) return prt_fail(L->err, "%s: out of memory", L->name);
    for (int v = 0; v < m->nverts; v++) map[v] = UINT32_MAX;
    for (size_t i = 0; i < 3 * nt; i++) map[m->tris[i]] = 0;
    uint32_t nk = 0;
    for (int v = 0; v < m->nverts; v++) {
        if (map[v] == UINT32_MAX) continue;
        if (nk != (uint32_t)v) {
            memcpy(m->pos + 3 * (size_t)nk, m->pos + 3 * (size_t)v, 3 * sizeof(float));
            memcpy(m->nrm + 3 * (size_t)nk, m->nrm + 3 * (size_t)v, 3 * sizeof(float));
            m->mat[nk] = m->mat[v];
            memcpy(m->uv + 2 * (size_t)nk, m->uv + 2 * (size_t)v, 2 * sizeof(float));
            L->bad_normal[nk] = L->bad_normal[v];
        }
        map[v] = nk++;
    }
    for (size_t i = 0; i < 3 * nt; i++) m->tris[i] = map[m->tris[i]];
    L->out->stats.unused = m->nverts - (int)nk;
    m->nverts = (int)nk;
    free(map);
    return 0;
}

/* Normals for the vertices flagged bad: mesh_compute_normals' angle-weighted ones (the file's
 * stay where they are usable). */
static int fill_normals(loader *L) {
    prt_mesh *m = &L->out->mesh;
    int bad = 0;
    for (int v = 0; v < m->nverts; v++) bad += L->bad_normal[v];
    if (!bad) return 0;
    float *keep = malloc(3 * (size_t)m->nverts * sizeof *keep);
    if (!keep) return prt_fail(L->err, "%s: out of memory", L->name);
    memcpy(keep, m->nrm, 3 * (size_t)m->nverts * sizeof *keep);
    mesh_compute_normals(m);
    for (int v = 0; v < m->nverts; v++)
        if (!L->bad_normal[v]) memcpy(m->nrm + 3 * (size_t)v, keep + 3 * (size_t)v, 3 * sizeof *keep);
    free(keep);
    return 0;
}

/* ---------------------------------------------------------------- lights and cameras */

/* One assimp light into prt's (asset.h: candela / 683, colour normalized to its largest channel).
 * Returns 1 when added, 0 when skipped with a note, -1 on error. */
static int put_light(loader *L, const struct aiLight *al) {
    const char *nm = al->mName.data, *file = base_name(L->name);
    if (al->mType != aiLightSource_POINT && al->mType != aiLightSource_SPOT) {
        scene_note(L->s, "%s: light '%.60s' skipped: prt's local lights are point and spot lights (%s)", file, nm,
                   al->mType == aiLightSource_DIRECTIONAL ? "a directional light is the probe's job" : "another kind");
        return 0;
    }
    double G[16];
    const double I4[16] = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1 };
    if (!node_find(L->ai->mRootNode, I4, nm, G, 0)) memcpy(G, I4, sizeof G);
    prt_light l = { .type = al->mType == aiLightSource_SPOT ? PRT_LIGHT_SPOT : PRT_LIGHT_POINT };
    const float p[3] = { al->mPosition.x, al->mPosition.y, al->mPosition.z }, d[3] = { al->mDirection.x, al->mDirection.y, al->mDirection.z };
    mat_apply(G, p, 1, l.pos);
    const float c[3] = { al->mColorDiffuse.r, al->mColorDiffuse.g, al->mColorDiffuse.b };
    float mx = fmaxf(c[0], fmaxf(c[1], c[2]));
    l.intensity = (float)(mx / ASSET_LM_PER_W);
    for (int k = 0; k < 3; k++) l.colour[k] = mx > 0 ? c[k] / mx : 1;
    if (l.type == PRT_LIGHT_SPOT) {
        mat_apply(G, d, 0, l.dir);
        float n = v3_len(l.dir);
        if (n > 0) v3_scale(l.dir, l.dir, 1 / n);
        l.inner_deg = (float)(al->mAngleInnerCone * 180 / M_PI);
        l.outer_deg = (float)(al->mAngleOuterCone * 180 / M_PI);
    } else l.dir[1] = -1;
    char what[200];
    snprintf(what, sizeof what, "%s: light '%.60s'", L->name, nm);
    return lights_add(&L->out->lights, &l, what, L->err) ? -1 : 1;
}

/* One assimp camera into a scene camera (asset.h); target on its axis at the model's centre's depth. */
static int put_camera(loader *L, const struct aiCamera *ac) {
    const char *nm = ac->mName.data;
    if (ac->mOrthographicWidth > 0) {
        scene_note(L->s, "%s: camera '%.60s' skipped: orthographic (prt's cameras are perspective)", base_name(L->name), nm);
        return 0;
    }
    if (L->out->ncameras >= SCENE_MAX_CAMERAS)
        return prt_fail(L->err, "%s: more than %d cameras", L->name, SCENE_MAX_CAMERAS);
    double G[16];
    const double I4[16] = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1 };
    if (!node_find(L->ai->mRootNode, I4, nm, G, 0)) memcpy(G, I4, sizeof G);
    scene_camera *sc = &L->out->cameras[L->out->ncameras];
    memset(sc, 0, sizeof *sc);
    for (size_t i = 0; nm[i] && i + 1 < sizeof sc->name; i++) sc->name[i] = nm[i] >= 32 && nm[i] < 127 ? nm[i] : '?';
    /* A glTF camera sits at its node's origin; assimp 5.2 also copies the node's translation into
     * mPosition, which the node transform then applies a second time. */
    const float p[3] = { L->fmt == FMT_GLTF ? 0 : ac->mPosition.x, L->fmt == FMT_GLTF ? 0 : ac->mPosition.y,
                         L->fmt == FMT_GLTF ? 0 : ac->mPosition.z };
    const float f[3] = { ac->mLookAt.x, ac->mLookAt.y, ac->mLookAt.z }, u[3] = { ac->mUp.x, ac->mUp.y, ac->mUp.z };
    float fw[3], lo[3], hi[3], ctr[3], to[3];
    mat_apply(G, p, 1, sc->cam.eye);
    mat_apply(G, f, 0, fw);
    mat_apply(G, u, 0, sc->cam.up);
    float fl = v3_len(fw);
    double yfov = ac->mAspect > 0 ? ac->mHorizontalFOV / ac->mAspect : ac->mHorizontalFOV;
    sc->cam.fov_deg = (float)(yfov * 180 / M_PI);
    if (!(fl > 0) || !isfinite(fl) || !(sc->cam.fov_deg > 0 && sc->cam.fov_deg < 180) || !isfinite(v3_len(sc->cam.eye)))
        return prt_fail(L->err, "%s: camera '%.60s': degenerate (view axis, field of view %g deg)", L->name, nm, (double)sc->cam.fov_deg);
    v3_scale(fw, fw, 1 / fl);
    mesh_bounds(&L->out->mesh, lo, hi);
    for (int k = 0; k < 3; k++) ctr[k] = 0.5f * (lo[k] + hi[k]);
    v3_sub(to, ctr, sc->cam.eye);
    float dist = v3_dot(to, fw);
    if (!(dist > 1e-6f * (v3_len(to) + 1e-30f))) dist = v3_len(to) > 0 ? v3_len(to) : 1;
    for (int k = 0; k < 3; k++) sc->cam.target[k] = sc->cam.eye[k] + dist * fw[k];
    const prt_camera *k = &sc->cam;   /* a transform of a huge scale, or a target past float's range */
    const float all[9] = { k->eye[0], k->eye[1], k->eye[2], k->target[0], k->target[1], k->target[2], k->up[0], k->up[1], k->up[2] };
    for (int i = 0; i < 9; i++)
        if (!isfinite(all[i])) return prt_fail(L->err, "%s: camera '%.60s': non-finite position or axes", L->name, nm);
    if (k->eye[0] == k->target[0] && k->eye[1] == k->target[1] && k->eye[2] == k->target[2])
        return prt_fail(L->err, "%s: camera '%.60s': its target is its eye", L->name, nm);
    L->out->ncameras++;
    return 1;
}

/* ---------------------------------------------------------------- loading */

/* assimp's steps per format: points and lines sorted out to be skipped, the data structure
 * validated (polygons are fanned into triangles here, put_mesh: assimp 5.2's triangulation asserts
 * on faces a malformed PLY gives it, and aborts; a PLY takes no step but the validation, its
 * post-processing having crashed on malformed bodies too, and gets prt's own smooth normals); OBJ's per-corner vertices joined; normals made where the file has
 * none (glTF: flat, its rule; PLY and OBJ: smooth). */
static unsigned import_flags(asset_format fmt) {
    unsigned f = aiProcess_SortByPType | aiProcess_ValidateDataStructure;
    if (fmt == FMT_PLY) return aiProcess_ValidateDataStructure;   /* indexed already; normals: fill_normals */
    if (fmt == FMT_OBJ) f |= aiProcess_JoinIdenticalVertices;
    return f | (fmt == FMT_GLTF ? aiProcess_GenNormals : aiProcess_GenSmoothNormals);
}

static asset_format format_of(const char *ext) {
    return !strcmp(ext, "ply") ? FMT_PLY : !strcmp(ext, "obj") ? FMT_OBJ : FMT_GLTF;
}

/* The notes a load leaves (skipped primitives, skinned and morphed meshes). */
static void load_notes(loader *L) {
    const char *file = base_name(L->name);
    if (L->skipped_prims)
        scene_note(L->s, "%s: %d mesh instance(s) of points or lines skipped (prt samples surfaces)", file, L->skipped_prims);
    if (L->skinned) scene_note(L->s, "%s: %d skinned mesh instance(s) taken at rest (bind pose, bones ignored)", file, L->skinned);
    if (L->morphed) scene_note(L->s, "%s: %d morphed mesh instance(s) taken at their base shape (morph targets ignored)", file, L->morphed);
}

/* The aiScene into L->out: meshes, the triangle count check, normals, lights, cameras. */
static int convert(loader *L, const gltf_info *gi) {
    const struct aiScene *ai = L->ai;
    if (!ai->mRootNode) return prt_fail(L->err, "%s: no scene (no root node)", L->name);
    L->mat_index = malloc((ai->mNumMaterials + 1) * sizeof *L->mat_index);
    L->mat_uv = calloc(ai->mNumMaterials + 1, sizeof *L->mat_uv);
    if (!L->mat_index || !L->mat_uv) return prt_fail(L->err, "%s: out of memory", L->name);
    for (unsigned i = 0; i < ai->mNumMaterials; i++) L->mat_index[i] = -1;
    if (L->fmt == FMT_GLTF && gi->triangles >= 0) {
        long long got = 0;
        for (unsigned i = 0; i < ai->mNumMeshes; i++)
            if (ai->mMeshes[i]->mPrimitiveTypes & aiPrimitiveType_TRIANGLE) got += ai->mMeshes[i]->mNumFaces;
        if (got < gi->triangles)
            return prt_fail(L->err, "%s: %lld of its %lld triangles refer to vertices out of range", L->name, gi->triangles - got,
                            gi->triangles);
    }
    const double I4[16] = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1 };
    if (walk(L, ai->mRootNode, I4, 0) || drop_unused(L) || fill_normals(L)) return -1;
    if (!L->textured) {   /* coordinates only where a texture reads them */
        free(L->out->mesh.uv);
        L->out->mesh.uv = NULL;
    }
    for (unsigned i = 0; i < ai->mNumLights; i++)
        if (put_light(L, ai->mLights[i]) < 0) return -1;
    for (unsigned i = 0; i < ai->mNumCameras; i++)
        if (put_camera(L, ai->mCameras[i]) < 0) return -1;
    load_notes(L);
    return 0;
}

/* Runs convert on an imported scene (NULL: assimp's error) and releases it. */
static int finish(loader *L, const struct aiScene *ai, const gltf_info *gi) {
    memset(L->out, 0, sizeof *L->out);
    if (!ai) {
        const char *why = aiGetErrorString();
        return prt_fail(L->err, "%s: %s", L->name, why && *why ? why : "assimp could not read it");
    }
    L->ai = ai;
    int rc = convert(L, gi);
    if (rc) asset_model_free(L->out);
    free(L->mat_index);
    free(L->mat_uv);
    free(L->bad_normal);
    aiReleaseImport(ai);
    return rc;
}

int asset_load(const char *path, const asset_desc *desc, prt_scene *s, asset_model *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    struct stat sb;
    if (stat(path, &sb) != 0) return prt_fail(err, "%s: cannot open: %s", path, strerror(errno));
    if (!S_ISREG(sb.st_mode)) return prt_fail(err, "%s: not a regular file", path);
    if (sb.st_size == 0) return prt_fail(err, "%s: empty file", path);
    char ext[16];
    prt_path_ext(path, ext);
    loader L = { .name = path, .fmt = format_of(ext), .desc = desc, .s = s, .out = out, .err = err };
    gltf_info gi = { .triangles = -1 };
    if (L.fmt == FMT_GLTF) gltf_inspect_file(path, (size_t)sb.st_size, s, &gi);
    if (gi.invalid[0]) return prt_fail(err, "%s: %s", path, gi.invalid);
    if (L.fmt == FMT_GLTF && !gi.json_ok) return prt_fail(err, "%s: not a glTF 2.0 file (neither a .glb nor JSON)", path);
    if ((L.fmt == FMT_OBJ && check_file(obj_check_text, path, err)) || (L.fmt == FMT_PLY && check_file(ply_check, path, err))) return -1;
    return finish(&L, aiImportFile(path, import_flags(L.fmt)), &gi);
}

int asset_load_memory(const char *name, const char *hint, const void *buf, size_t len, const asset_desc *desc,
                      prt_scene *s, asset_model *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    if (len == 0) return prt_fail(err, "%s: empty file", name);
    if (len > UINT32_MAX) return prt_fail(err, "%s: too large", name);
    loader L = { .name = name, .fmt = format_of(hint), .desc = desc, .s = s, .out = out, .err = err, .from_memory = true };
    gltf_info gi = { .triangles = -1 };
    size_t jl = 0;
    const char *js = L.fmt == FMT_GLTF ? gltf_json(buf, len, &jl, &gi) : NULL;
    if (js) gltf_inspect(name, js, jl, s, &gi);
    if (gi.external[0])
        return prt_fail(err, "%s: names the file '%s' (a glTF read from memory has no folder to open it in)", name, gi.external);
    if (gi.invalid[0]) return prt_fail(err, "%s: %s", name, gi.invalid);
    if (L.fmt == FMT_GLTF && !gi.json_ok) return prt_fail(err, "%s: not a glTF 2.0 file (neither a .glb nor JSON)", name);
    if ((L.fmt == FMT_OBJ && check_memory(obj_check_text, name, buf, len, err)) ||
        (L.fmt == FMT_PLY && check_memory(ply_check, name, buf, len, err))) return -1;
    return finish(&L, aiImportFileFromMemory(buf, (unsigned)len, import_flags(L.fmt), hint), &gi);
}
