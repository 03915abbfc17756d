// The FMU exporter's C runtime (core/fmu/runtime.c) and the FMI 2.0 standard's headers and their
// licence (core/fmu/fmi2), as text compiled into the library by core/fmu/embed.cmake.
#pragma once

namespace gb::fmu::embedded {

extern const char kRuntime[];        // runtime.c
extern const char kSensor[];         // sensor.c (the virtual sensor's filter)
extern const char kTypesPlatform[];  // fmi2TypesPlatform.h
extern const char kFunctionTypes[];  // fmi2FunctionTypes.h
extern const char kFunctions[];      // fmi2Functions.h
extern const char kLicence[];        // the headers' BSD 2-Clause licence

}  // namespace gb::fmu::embedded
