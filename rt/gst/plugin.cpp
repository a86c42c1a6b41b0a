// The nvstim GStreamer plugin (libgstnvstim.so): registers the element nvstimsrc
// (docs/gstreamer.md).

#include <gst/gst.h>

#include "rt/gst/nvstim_src.h"

#define PACKAGE "nvstim"  // GST_PLUGIN_DEFINE names the package by this macro

namespace {

gboolean pluginInit(GstPlugin* plugin) {
    return gst_element_register(plugin, "nvstimsrc", GST_RANK_NONE, GST_TYPE_NVSTIM_SRC);
}

}  // namespace

// GStreamer finds the plugin by its file name, libgst<name>.so, and this symbol in it. The
// license string is one GStreamer accepts; the project names no open-source license.
GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, nvstim,
                  "nvstim: night-vision camera stimulator frames as a video source", pluginInit,
                  NVS_VERSION, "Proprietary", "nvstim", "nvstim")
