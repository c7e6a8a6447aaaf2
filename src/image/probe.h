/* probe.h - HDR light probes: loading, layouts, lookup, resampling to the cube
 * map, and the procedural sky used by the demo and the tests.
 *
 * Direction convention (world frame, y up). Latitude-longitude: a direction
 * d maps to u = 0.5 + atan2(d.x, -d.z) / (2 pi), v = acos(d.y) / pi (u, v in
 * [0,1], v = 0 at the zenith, the image's top row). Angular map (Debevec light probe): r =
 * acos(-d.z) / pi, (u, v) = (0.5 + 0.5 r d.x / |d.xy|, 0.5 - 0.5 r d.y / |d.xy|).
 * Vertical cross (3:4) and horizontal cross (4:3): faces laid out as in
 * Debevec's probes (documented in probe.c).
 * Layout detection from the aspect ratio: 2:1 latlong, 1:1 angular, 3:4 or 4:3
 * cross; a flag overrides it.
 *
 * Negative and non-finite texels are clamped to 0 on load and counted
 * (clamped_negative, clamped_nonfinite) so the caller can warn. How much light the
 * negative ones held is clamped_negative_share: their |value| times solid angle over
 * the whole probe's. Lossy compression leaves a few tiny negatives in many HDR
 * probes (1e-11 to 1e-6 of the light in common ones), whose clamping changes nothing
 * visible, so a caller says so only above PROBE_NEGATIVE_NOTE.
 *
 * Resampling (probe_to_cube): each cube texel is the solid-angle-weighted mean
 * of the probe over the texel, estimated with ss x ss stratified sub-samples
 * each bilinearly filtered (not point sampling), and with the probe rotated by R
 * (row-major 3x3, applied to the lighting: a light at direction d moves to R d).
 * Texels that a pixel far brighter than the mean reaches (a sun) are sampled
 * more finely (sub-samples a quarter pixel apart, up to 64 x 64), so that a sun
 * one pixel wide keeps its power at any probe resolution (see probe.c).
 *
 * Ownership: the probe owns its image; probe_free frees it. */
#ifndef PRT_PROBE_H
#define PRT_PROBE_H
#include "common.h"
#include "image.h"

/* PROBE_CROSS (input only): a vertical or horizontal cross, whichever the aspect says. */
typedef enum probe_layout { PROBE_AUTO = 0, PROBE_LATLONG, PROBE_ANGULAR, PROBE_VCROSS, PROBE_HCROSS, PROBE_CROSS } probe_layout;

typedef struct prt_probe {
    prt_image img;          /* RGB, clamped to finite, >= 0 */
    probe_layout layout;
    long clamped_negative;  /* texels that had a negative channel */
    long clamped_nonfinite; /* texels that had a NaN or Inf channel */
    double clamped_negative_share;   /* the negative channels' share of the light (see above) */
    float max_value;        /* largest channel value after clamping */
} prt_probe;

/* The negative share worth a word: clamping then changes the light by more than 0.01%. */
#define PROBE_NEGATIVE_NOTE 1e-4

/* Parses "latlong", "angular", "vcross", "hcross", "cross" (auto cross), "auto". Returns -1 if unknown. */
int probe_parse_layout(const char *s, probe_layout *out);
/* Name of a layout ("latlong", ...), static storage. */
const char *probe_layout_name(probe_layout l);
/* Loads a probe image file with OIIO and detects its layout (unless given). */
int probe_load(const char *path, probe_layout layout, prt_probe *out, prt_error *err);
/* Takes ownership of an image as a probe (layout AUTO detects), clamping as on load.
 * *img is zeroed on return; on failure its pixels are freed. RGBA loses its alpha. */
int probe_from_image(prt_image *img, probe_layout layout, const char *name, prt_probe *out, prt_error *err);

/* Procedural sky: a zenith-to-horizon gradient, a darker ground, and a small sun of the given
 * angular radius (degrees) in direction sun_dir whose disc has radiance sun_radiance.
 * Zero fields mean defaults (w 512, sun at elevation 45 deg, radius 1.5 deg, radiance 2000). */
typedef struct sky_desc {
    int width;              /* latlong width (height = width/2) */
    float sun_dir[3];
    float sun_radius_deg;
    float sun_radiance;
    float sky_zenith[3], sky_horizon[3], ground[3];
} sky_desc;
int probe_make_sky(const sky_desc *desc, prt_probe *out, prt_error *err);
/* A constant environment of radiance rgb (for tests). */
int probe_make_constant(const float rgb[3], prt_probe *out, prt_error *err);

/* Bilinear radiance in direction d (unit). */
void probe_eval(const prt_probe *p, const float d[3], float rgb[3]);
/* Direction of the centre of pixel (x, y) and the pixel's solid angle (for importance sampling);
 * returns false for pixels outside the layout's valid area (angular / cross gaps). */
bool probe_pixel_dir(const prt_probe *p, int x, int y, float d[3], float *solid_angle);

/* Cube map of the probe: out[CUBE texel][3] (interleaved RGB, cubemap.h indexing), rotated by R
 * (NULL = identity), ss x ss sub-samples per texel (0 = 4, at most 64). Uses both cores. */
void probe_to_cube(const prt_probe *p, int res, const float R[9], int ss, float *out_rgb);

/* The exposure in stops (clamped to +-PROBE_EXPOSURE_MAX) at which a white Lambertian surface facing
 * up (+y) under p rotated by R (NULL = identity) shows as 1: -log2(E_up / pi), E_up the probe's
 * irradiance on it (a 32^3 cube, Eq. 3's texels with their solid angle). Render and reference take it
 * from the light, not the image, so the two pictures of one scene get the same exposure. 0 for a
 * probe without light above the horizon. */
#define PROBE_EXPOSURE_MAX 30.0f
float probe_exposure(const prt_probe *p, const float R[9]);

/* Rotation matrix for --light-rotation "Y" or "Y,P" (degrees about +y, then pitch about +x). Returns -1 if unparsable. */
int probe_parse_rotation(const char *s, float R[9]);
/* The same rotation from yaw and pitch in degrees. */
void probe_rotation(double yaw, double pitch, float R[9]);

void probe_free(prt_probe *p);
#endif
