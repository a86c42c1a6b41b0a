#include "rt/run/telemetry_factory.h"

#include <charconv>
#include <cstdlib>
#include <cstring>

#include "drivers/gpio/gpio.h"
#include "drivers/v4l2/v4l2.h"
#include "rt/telemetry/sources.h"
#include "sim/core/error.h"

namespace nvs::rt {

namespace {

drivers::DbcDatabase loadDbc(Spec& spec, const std::filesystem::path& configDir) {
    const auto path = spec.take("dbc");
    return drivers::DbcDatabase::load(path ? *path : (configDir / "can" / "nvstim.dbc").string());
}

}  // namespace

std::unique_ptr<FrameSink> makeDeviceSink(Spec& spec, const Scenario& sc, const std::string& what) {
    if (spec.scheme == "v4l2") {
        // Default format: GREY for ADCs of up to 8 bits, Y16 above (no precision thrown away).
        drivers::V4l2Format format =
            sc.bits > 8 ? drivers::V4l2Format::Y16 : drivers::V4l2Format::Grey;
        if (const auto f = spec.take("format")) {
            if (!drivers::parseV4l2Format(*f, &format)) {
                throw SetupError(what + ": format must be GREY, Y16 or YUYV, not '" + *f + "'");
            }
        }
        drivers::V4l2Io io = drivers::V4l2Io::Write;
        if (const auto m = spec.take("io")) {
            if (*m == "mmap") {
                io = drivers::V4l2Io::Mmap;
            } else if (*m != "write") {
                throw SetupError(what + ": io must be write or mmap, not '" + *m + "'");
            }
        }
        return std::make_unique<drivers::V4l2Sink>(std::make_unique<drivers::KernelV4l2Ops>(),
                                                   spec.target, sc.width, sc.height, sc.bits,
                                                   format, io, sc.fieldOrder());
    }
    if (spec.scheme == "gpio") {
        // gpio:CHIP:LINE[?active=high|low]
        std::string chip;
        unsigned line = 0;
        if (!drivers::parseGpioTarget(spec.target, &chip, &line)) {
            throw SetupError(what + ": expected gpio:CHIP:LINE (e.g. gpio:gpiochip0:17)");
        }
        bool activeLow = false;
        if (const auto a = spec.take("active")) {
            if (*a != "high" && *a != "low") {
                throw SetupError(what + ": active must be high or low, not '" + *a + "'");
            }
            activeLow = *a == "low";
        }
        return std::make_unique<drivers::GpioGateSink>(std::make_unique<drivers::GpiodLine>(), chip,
                                                       line, activeLow);
    }
    return nullptr;
}

std::unique_ptr<TriggerSource> makeTrigger(const std::string& text, const std::string& what) {
    std::string chip;
    unsigned line = 0;
    if (text.rfind("gpio:", 0) != 0 || !drivers::parseGpioTarget(text.substr(5), &chip, &line)) {
        throw SetupError(what + " '" + text + "': expected gpio:CHIP:LINE");
    }
    return std::make_unique<drivers::GpioTrigger>(std::make_unique<drivers::GpiodLine>(), chip,
                                                  line);
}

std::unique_ptr<PlatformSource> makeTelemetrySource(Spec& spec, const Scenario& sc, ClockKind clock,
                                                    const std::string& what,
                                                    const std::filesystem::path& configDir,
                                                    const std::atomic<bool>* stop) {
    std::unique_ptr<TelemetryInput> input;
    if (spec.scheme == "replay") {
        input = std::make_unique<ReplayInput>(spec.target, loadDbc(spec, configDir));
    } else if (spec.scheme == "can" || spec.scheme == "serial") {
        if (spec.scheme == "can") {
            const auto fd = spec.take("fd");
            const auto record = spec.take("record");
            // Under the sim clock the loop steps in lockstep with the telemetry's own time
            // signal (rt/telemetry/sources.h): frames wait for it, arrival times do not count.
            CanLockstep lockstep;
            lockstep.enabled = clock == ClockKind::Sim;
            lockstep.stop = stop;
            if (const auto idle = spec.take("idle_s")) {
                char* end = nullptr;
                lockstep.idle_s = std::strtod(idle->c_str(), &end);
                if (end == idle->c_str() || *end != '\0' || !(lockstep.idle_s > 0.0)) {
                    throw SetupError(what + ": idle_s must be a positive number of seconds");
                }
                if (!lockstep.enabled) throw SetupError(what + ": idle_s needs --clock sim");
            }
            input = std::make_unique<CanInput>(
                std::make_unique<drivers::SocketCanBus>(), spec.target, fd && *fd == "1",
                loadDbc(spec, configDir), record ? *record : "", lockstep);
        } else {
            if (clock == ClockKind::Sim) {
                throw SetupError(what +
                                 ": serial telemetry needs --clock wall (it carries no time of "
                                 "its own to step the sim clock by)");
            }
            const auto baud = spec.take("baud");
            const auto proto = spec.take("proto");
            // from_chars, not atoi: atoi of a number beyond int is undefined behaviour.
            int b = 115200;
            if (baud) {
                const auto r = std::from_chars(baud->data(), baud->data() + baud->size(), b);
                if (r.ec != std::errc() || r.ptr != baud->data() + baud->size()) b = 0;
            }
            if (drivers::baudConstant(b) == 0) throw SetupError(what + ": unsupported baud rate");
            if (!proto || (*proto != "nmea" && *proto != "mavlink")) {
                throw SetupError(what + ": proto must be nmea or mavlink");
            }
            input = std::make_unique<SerialInput>(
                std::make_unique<drivers::TermiosSerialPort>(), spec.target, b,
                *proto == "nmea" ? SerialInput::Proto::Nmea : SerialInput::Proto::Mavlink);
        }
    } else {
        throw SetupError(what + ": unknown telemetry scheme '" + spec.scheme +
                         "' (known: can, serial, replay)");
    }
    return std::make_unique<TelemetryPlatform>(std::move(input), sc.platform, sc.staleAfter_s,
                                               sc.maxExtrapolation_s, sc.badInputFatal);
}

}  // namespace nvs::rt
