/* Develops a raw Bayer frame with camsim's fixed-point ISP through its C API, in bands of 16
 * rows, with no allocation by the library: the pipeline lives in static storage, the scratch
 * is the caller's.
 *
 *   develop RAW WIDTH HEIGHT OUT
 *
 * RAW is WIDTH x HEIGHT little-endian uint16_t samples (10-bit RGGB, black 64, white 1023);
 * OUT receives 8-bit interleaved RGB. The configuration is a camera's: dynamic and static
 * defect correction, white balance, MHC demosaicing, raw and chroma noise reduction,
 * highlight recovery, a colour matrix and a vivid look. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camsim_isp.h"

#define MAX_PIXELS (4096u * 3072u)
#define BAND_ROWS 16u

/* The pipeline's storage: static, over-aligned; checked against the library's query (about
 * 27 KiB on a 64-bit host, most of it noise reduction's three stabiliser tables and the tone
 * table). */
static _Alignas(16) unsigned char pipeline_storage[32768];

static const CamsimDefect static_defects[] = {{3, 5}, {10, 40}, {17, 22}};

static int fail(const char *what, CamsimStatus status) {
    fprintf(stderr, "error: %s: %s\n", what, camsim_status_message(status));
    return 1;
}

int main(int argc, char **argv) {
    if (argc != 5) {
        fprintf(stderr, "usage: %s RAW WIDTH HEIGHT OUT\n", argv[0]);
        return 2;
    }
    unsigned long width = strtoul(argv[2], NULL, 10), height = strtoul(argv[3], NULL, 10);
    if (width == 0 || height == 0 || width * height > MAX_PIXELS) {
        fprintf(stderr, "error: the frame must be 1..%u pixels\n", MAX_PIXELS);
        return 2;
    }
    size_t pixels = (size_t)width * height;
    uint16_t *raw = malloc(pixels * sizeof *raw);
    uint8_t *rgb = malloc(3 * pixels);
    FILE *in = fopen(argv[1], "rb");
    if (raw == NULL || rgb == NULL || in == NULL) {
        fprintf(stderr, "error: cannot read %s\n", argv[1]);
        return 1;
    }
    unsigned char pair[2];
    for (size_t i = 0; i < pixels; i++) {
        if (fread(pair, 1, 2, in) != 2) {
            fprintf(stderr, "error: %s holds fewer than %zu samples\n", argv[1], pixels);
            return 1;
        }
        raw[i] = (uint16_t)(pair[0] | pair[1] << 8);
    }
    fclose(in);

    CamsimIspConfig config;
    camsim_isp_config_default(&config);
    config.demosaic = CAMSIM_DEMOSAIC_MHC;
    config.out_bits = 8;
    config.wb_gains[0] = 1.9f;
    config.wb_gains[1] = 1.0f;
    config.wb_gains[2] = 1.6f;
    const float ccm[3][3] = {{1.6f, -0.4f, -0.2f}, {-0.3f, 1.5f, -0.2f}, {0.0f, -0.5f, 1.5f}};
    memcpy(config.ccm, ccm, sizeof ccm);
    config.highlight_knee = 0.9f;
    config.denoise = 1.0f;
    config.noise_scale = 0.0008f;
    config.noise_offset = 4.3295e-6f;
    config.chroma_denoise = 1.0f;
    config.saturation = 1.3f;
    config.contrast = 1.15f;
    config.dpc_threshold = 64;
    config.static_defects = static_defects;
    config.static_defect_count = sizeof static_defects / sizeof static_defects[0];

    char message[160];
    if (camsim_isp_config_error(&config, message, sizeof message) != 0) {
        fprintf(stderr, "error: %s\n", message);
        return 1;
    }
    if (camsim_isp_pipeline_size() > sizeof pipeline_storage ||
        camsim_isp_pipeline_align() > 16) {
        fprintf(stderr, "error: the pipeline needs %zu bytes aligned to %zu\n",
                camsim_isp_pipeline_size(), camsim_isp_pipeline_align());
        return 1;
    }
    const CamsimIspPipeline *pipeline;
    CamsimStatus status =
        camsim_isp_pipeline_init(pipeline_storage, sizeof pipeline_storage, &config, &pipeline);
    if (status != CAMSIM_STATUS_OK) return fail("camsim_isp_pipeline_init", status);

    size_t scratch_len;
    status = camsim_isp_scratch_len(pipeline, (uint32_t)width, (uint32_t)height, &scratch_len);
    if (status != CAMSIM_STATUS_OK) return fail("camsim_isp_scratch_len", status);
    uint16_t *scratch = malloc(scratch_len * sizeof *scratch);
    if (scratch == NULL) return 1;

    CamsimRawFrame frame = {
        .data = raw,
        .width = (uint32_t)width,
        .height = (uint32_t)height,
        .stride = (uint32_t)width,
        .bit_depth = 10,
        .pattern = CAMSIM_CFA_RGGB,
        .black_level = {64, 64, 64, 64},
        .white_level = 1023,
    };
    for (uint32_t row = 0; row < height; row += BAND_ROWS) {
        uint32_t rows = height - row < BAND_ROWS ? (uint32_t)(height - row) : BAND_ROWS;
        uint8_t *band = rgb + (size_t)row * 3 * width;
        status = camsim_isp_run_rows(pipeline, &frame, row, rows, scratch, scratch_len, band,
                                     (size_t)rows * 3 * width, (uint32_t)(3 * width));
        if (status != CAMSIM_STATUS_OK) return fail("camsim_isp_run_rows", status);
    }

    FILE *out = fopen(argv[4], "wb");
    if (out == NULL || fwrite(rgb, 1, 3 * pixels, out) != 3 * pixels || fclose(out) != 0) {
        fprintf(stderr, "error: cannot write %s\n", argv[4]);
        return 1;
    }
    free(scratch);
    free(rgb);
    free(raw);
    return 0;
}
