#pragma once
// nvstimsrc: a GStreamer source element whose frames are those of an `nvstim run` of a scenario
// (rt/session), as GRAY8 or GRAY16_LE video with the frames' exposure mid-times as time stamps
// (docs/gstreamer.md; the contract in docs/contracts.md, "GStreamer source").

#include <gst/base/gstpushsrc.h>

G_BEGIN_DECLS

#define GST_TYPE_NVSTIM_SRC (gst_nvstim_src_get_type())
G_DECLARE_FINAL_TYPE(GstNvstimSrc, gst_nvstim_src, GST, NVSTIM_SRC, GstPushSrc)

// The element's `clock` property: the run's clock (`nvstim run --clock`).
#define GST_TYPE_NVSTIM_CLOCK (gst_nvstim_clock_get_type())
GType gst_nvstim_clock_get_type(void);

G_END_DECLS
