/* image_oiio.cpp - float RGB(A) image input and output through OpenImageIO
 * (see image.h).
 *
 * OpenImageIO has only a C++ API, so this file is the one piece of C++ in
 * prt: it exposes the extern "C" functions of image.h and lets no exception
 * escape (every entry point catches everything and turns it into a prt_error
 * line naming the file).
 *
 * Reading: subimage 0, MIP level 0, converted by OIIO to float. Integer
 * formats (PNG, JPEG, 8/16-bit TIFF, PPM) hold sRGB-encoded values, so they
 * are decoded to linear here unless the file declares itself linear; float
 * formats (EXR, HDR, PFM) are taken as linear. The result always has three
 * channels: one- and two-channel (grey, grey+alpha) images are replicated,
 * alpha and any extra channels are dropped.
 *
 * Writing: float formats (.exr, .hdr) store linear values, non-finite
 * ones as 0 (and, for half EXR, clamped to the half range so nothing turns
 * into Inf). 8-bit formats get exposure, a tone map and the sRGB transfer
 * curve, then are rounded to the nearest code value. OIIO encodes into memory
 * (an IOVecOutput proxy; every writer prt uses supports it) and the bytes go
 * through prt_atomic_open/commit ("<path>.tmp.<pid>", every write, the flush
 * and the close checked, then renamed), because OIIO's PNG writer ignores a
 * short write: a full disk must fail, not leave a cut PNG. */
/* common.h has no extern "C" guard of its own (it is a C header). */
extern "C" {
#include "common.h"
}
#include "image.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>
#include <sys/stat.h>
#include <unistd.h>

using namespace OIIO;

/* First line of an OIIO error string, trimmed (OIIO errors may span lines). */
static std::string first_line(const std::string &s) {
    size_t e = s.find_first_of("\r\n");
    std::string l = s.substr(0, e);
    while (!l.empty() && (l.back() == ' ' || l.back() == '\t')) l.pop_back();
    if (l.size() > 400) l = l.substr(0, 400) + "...";
    return l.empty() ? std::string("unknown error") : l;
}

/* sRGB transfer curve, encoded [0,1] to linear. */
static float srgb_to_linear(float v) {
    if (!(v > 0.f)) return 0.f;
    if (v >= 1.f) return 1.f;
    return v <= 0.04045f ? v / 12.92f : powf((v + 0.055f) / 1.055f, 2.4f);
}

/* Linear [0,1] to sRGB-encoded [0,1]. */
static float linear_to_srgb(float v) {
    if (!(v > 0.f)) return 0.f;
    if (v >= 1.f) return 1.f;
    return v <= 0.0031308f ? 12.92f * v : 1.055f * powf(v, 1.f / 2.4f) - 0.055f;
}

/* Tone map of a linear value already scaled by the exposure: 0 clamp, 1 Reinhard, 2 ACES (Narkowicz fit). */
static float tonemap(float x, int op) {
    if (!std::isfinite(x) || x <= 0.f) return 0.f;
    switch (op) {
    case 1: return x / (1.f + x);
    case 2: {
        float y = (x * (2.51f * x + 0.03f)) / (x * (2.43f * x + 0.59f) + 0.14f);
        return y < 0.f ? 0.f : (y > 1.f ? 1.f : y);
    }
    default: return x > 1.f ? 1.f : x;
    }
}

/* Does the file store display-referred (sRGB) integer values? */
static bool file_is_srgb(const ImageSpec &spec) {
    TypeDesc f = spec.format;
    if (f.basetype == TypeDesc::FLOAT || f.basetype == TypeDesc::HALF || f.basetype == TypeDesc::DOUBLE) return false;
    std::string cs = spec.get_string_attribute("oiio:ColorSpace");
    for (char &ch : cs) ch = (char)std::tolower((unsigned char)ch);
    if (cs == "linear" || cs == "scene_linear" || cs == "lin_srgb" || cs == "linear srgb") return false;
    return true;
}

static int image_decode(const char *path, Filesystem::IOProxy *proxy, prt_image *out, prt_error *err);

/* image_read's body (may throw; the wrapper catches). */
static int image_read_impl(const char *path, prt_image *out, prt_error *err) {
    struct stat st;
    if (stat(path, &st) != 0) return prt_fail(err, "%s: cannot open: %s", path, std::strerror(errno));
    if (S_ISDIR(st.st_mode)) return prt_fail(err, "%s: is a directory, not an image", path);
    if (!S_ISREG(st.st_mode)) return prt_fail(err, "%s: not a regular file", path);
    if (st.st_size == 0) return prt_fail(err, "%s: empty file", path);
    if (access(path, R_OK) != 0) return prt_fail(err, "%s: cannot read: %s", path, std::strerror(errno));

    return image_decode(path, nullptr, out, err);
}

/* Opens path (through proxy when non-null: bytes in memory, path then only names the format by
 * its extension) and reads it as linear RGB float. May throw; the wrappers catch. */
static int image_decode(const char *path, Filesystem::IOProxy *proxy, prt_image *out, prt_error *err) {
    /* Read alpha as stored: OIIO would otherwise premultiply PNG colours by alpha. */
    ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    if (proxy) config.attribute("oiio:ioproxy", TypeDesc::PTR, &proxy);   /* the plugins read it from here */
    auto in = ImageInput::open(path, &config, proxy);
    if (!in) {
        std::string e = first_line(OIIO::geterror());
        return prt_fail(err, "%s: not a readable image (%s)", path, e.c_str());
    }
    const ImageSpec &spec = in->spec();
    int w = spec.width, h = spec.height, nch = spec.nchannels;
    if (w <= 0 || h <= 0 || nch <= 0 || spec.depth > 1) {
        in->close();
        return prt_fail(err, "%s: image has zero size (%dx%d, %d channels)", path, w, h, nch);
    }
    if ((long long)w * h > IMAGE_MAX_PIXELS) {
        in->close();
        return prt_fail(err, "%s: image %dx%d too large", path, w, h);
    }
    int take = nch >= 3 ? 3 : (nch >= 1 ? 1 : 0);   /* RGB, or grey (replicated below) */
    std::vector<float> buf((size_t)w * h * take);
    if (!in->read_image(0, 0, 0, take, TypeDesc::FLOAT, buf.data())) {
        std::string e = first_line(in->geterror());
        in->close();
        return prt_fail(err, "%s: cannot read pixels (%s)", path, e.c_str());
    }
    bool srgb = file_is_srgb(spec);
    TypeDesc::BASETYPE bt = (TypeDesc::BASETYPE)spec.format.basetype;
    bool ldr = bt != TypeDesc::FLOAT && bt != TypeDesc::HALF && bt != TypeDesc::DOUBLE;
    in->close();

    if (image_alloc(out, w, h, 3, err)) return prt_fail(err, "%s: image %dx%d: out of memory", path, w, h);
    out->ldr = ldr;
    size_t n = (size_t)w * h;
    for (size_t i = 0; i < n; i++) {
        for (int ch = 0; ch < 3; ch++) {
            float v = buf[i * take + (take == 3 ? ch : 0)];
            out->data[3 * i + ch] = srgb ? srgb_to_linear(v) : v;
        }
    }
    return 0;
}

/* Reads path as linear RGB float; 0, or -1 with one line naming the file. Caller frees with image_free. */
extern "C" int image_read(const char *path, prt_image *out, prt_error *err) {
    std::memset(out, 0, sizeof *out);
    if (!path || !*path) return prt_fail(err, "empty image path");
    try {
        return image_read_impl(path, out, err);
    } catch (const std::exception &e) {
        image_free(out);
        return prt_fail(err, "%s: cannot read image: %s", path, e.what());
    } catch (...) {
        image_free(out);
        return prt_fail(err, "%s: cannot read image (unexpected error)", path);
    }
}

/* See image.h: bytes in memory through OIIO's memory reader. */
extern "C" int image_read_memory(const char *name, const void *buf, size_t len, prt_image *out, prt_error *err) {
    std::memset(out, 0, sizeof *out);
    if (!name || !*name) return prt_fail(err, "empty image name");
    if (len == 0) return prt_fail(err, "%s: empty image", name);
    try {
        Filesystem::IOMemReader mem(buf, len);
        return image_decode(name, &mem, out, err);
    } catch (const std::exception &e) {
        image_free(out);
        return prt_fail(err, "%s: cannot read image: %s", name, e.what());
    } catch (...) {
        image_free(out);
        return prt_fail(err, "%s: cannot read image (unexpected error)", name);
    }
}

/* The first oc channels of im as float, non-finite values 0 and clamped to the range of
 * half (EXR with desc.half) or float; returns the spec to write them with (zip for EXR). */
static ImageSpec float_pixels(const prt_image *im, int oc, bool exr, bool half, std::vector<float> &fbuf) {
    ImageSpec spec(im->w, im->h, oc, half ? TypeDesc::HALF : TypeDesc::FLOAT);
    if (exr) spec.attribute("compression", "zip");
    float lim = half ? 65504.f : 3.4028234e38f;
    size_t n = (size_t)im->w * im->h;
    fbuf.resize(n * oc);
    for (size_t i = 0; i < n; i++)
        for (int ch = 0; ch < oc; ch++) {
            float v = im->data[i * im->c + ch];
            if (!std::isfinite(v)) v = 0.f;
            fbuf[i * oc + ch] = v > lim ? lim : (v < -lim ? -lim : v);
        }
    return spec;
}

/* The first oc channels of im as 8-bit sRGB after exposure and tone mapping (alpha, channel 3,
 * stays linear and unassociated); returns the spec to write them with. */
static ImageSpec byte_pixels(const prt_image *im, int oc, const image_desc &d, std::vector<unsigned char> &bbuf) {
    ImageSpec spec(im->w, im->h, oc, TypeDesc::UINT8);
    spec.attribute("oiio:ColorSpace", "sRGB");
    if (oc == 4) spec.attribute("oiio:UnassociatedAlpha", 1);
    float gain = std::isfinite(d.exposure) ? std::exp2(d.exposure) : 1.f;
    size_t n = (size_t)im->w * im->h;
    bbuf.resize(n * oc);
    for (size_t i = 0; i < n; i++)
        for (int ch = 0; ch < oc; ch++) {
            float v = im->data[i * im->c + ch];
            float s;
            if (ch == 3) s = std::isfinite(v) ? (v < 0.f ? 0.f : (v > 1.f ? 1.f : v)) : 0.f;   /* alpha: linear */
            else s = linear_to_srgb(tonemap(v * gain, d.tonemap));
            bbuf[i * oc + ch] = (unsigned char)std::lround(s * 255.f);
        }
    return spec;
}

/* Writes n encoded bytes to path through prt_atomic_open / commit, which check every write,
 * the flush and the close (a full disk or a file-size limit fails here, naming path). */
static int write_bytes(const char *path, const unsigned char *p, size_t n, prt_error *err) {
    char tmp[4200];
    FILE *f = prt_atomic_open(path, tmp, sizeof tmp, err);
    if (!f) return -1;
    if (std::fwrite(p, 1, n, f) != n) {
        int en = errno;
        prt_atomic_abort(f, tmp);
        return prt_fail(err, "%s: write failed: %s", path, std::strerror(en));
    }
    return prt_atomic_commit(f, tmp, path, err);
}

/* image_write's body (may throw; the wrapper catches). */
/* See image.h: the formats written as 8-bit sRGB. */
extern "C" bool image_tonemapped(const char *path) {
    char ext[16];
    prt_path_ext(path, ext);
    std::string e(ext);
    return e == "png" || e == "jpg" || e == "jpeg" || e == "tif" || e == "tiff" || e == "ppm";
}

static int image_write_impl(const char *path, const prt_image *im, const image_desc *desc, prt_error *err) {
    if (!im || !im->data || im->w <= 0 || im->h <= 0 || (im->c != 3 && im->c != 4))
        return prt_fail(err, "%s: nothing to write (empty image)", path);
    image_desc d = {};
    if (desc) d = *desc;
    char ext[16];
    prt_path_ext(path, ext);
    std::string e(ext);
    bool is_float = e == "exr" || e == "hdr";
    bool is_8bit = image_tonemapped(path);
    if (!is_float && !is_8bit)
        return prt_fail(err, "%s: unsupported output format '.%s' (use .exr, .hdr, .png, .jpg, .tif or .ppm)", path,
                        ext);
    /* Channels written: RGB for formats without alpha (and for the float formats, per image.h), else as the image. */
    int oc = (e == "png" || e == "tif" || e == "tiff") ? im->c : 3;

    /* Encoded into memory, then written with checked writes: OIIO's PNG writer does not report
     * a short write (a full disk gave a cut PNG and "wrote"), so no format is trusted with the file. */
    auto out = ImageOutput::create(path);
    if (!out) {
        std::string m = first_line(OIIO::geterror());
        return prt_fail(err, "%s: no writer for '.%s' (%s)", path, ext, m.c_str());
    }
    if (!out->supports("ioproxy")) return prt_fail(err, "%s: the '.%s' writer cannot encode to memory", path, ext);
    ImageSpec spec;
    std::vector<float> fbuf;
    std::vector<unsigned char> bbuf, bytes;
    const void *pixels;
    TypeDesc ptype;
    if (is_float) {
        spec = float_pixels(im, oc, e == "exr", e == "exr" && d.half, fbuf);
        pixels = fbuf.data();
        ptype = TypeDesc::FLOAT;
    } else {
        spec = byte_pixels(im, oc, d, bbuf);
        pixels = bbuf.data();
        ptype = TypeDesc::UINT8;
    }
    Filesystem::IOVecOutput mem(bytes);
    out->set_ioproxy(&mem);
    bool ok = out->open(path, spec) && out->write_image(ptype, pixels);
    std::string m = ok ? std::string() : first_line(out->geterror());
    if (!out->close() && ok) {
        ok = false;
        m = first_line(out->geterror());
    }
    out.reset();
    if (!ok || bytes.empty()) return prt_fail(err, "%s: cannot encode the image (%s)", path, ok ? "no bytes" : m.c_str());
    return write_bytes(path, bytes.data(), bytes.size(), err);
}

/* Writes im to path in the format its extension names, atomically; 0, or -1 naming the file. */
extern "C" int image_write(const char *path, const prt_image *im, const image_desc *desc, prt_error *err) {
    if (!path || !*path) return prt_fail(err, "empty image path");
    if (std::strlen(path) > 4000) return prt_fail(err, "%.60s...: output path too long", path);
    try {
        return image_write_impl(path, im, desc, err);
    } catch (const std::exception &e) {
        return prt_fail(err, "%s: cannot write image: %s", path, e.what());
    } catch (...) {
        return prt_fail(err, "%s: cannot write image (unexpected error)", path);
    }
}
