/* SPDX-License-Identifier: MIT
 * cl_loader.h -- the OpenCL entry points pkss uses, resolved at run time.
 *
 * libpkss does not link libOpenCL: a machine without the ICD loader must
 * still load the library and use the reference backend. The first device
 * call dlopen()s the loader ($PKSS_OPENCL_LIBRARY if set, else
 * libOpenCL.so.1, else libOpenCL.so) once (pthread_once) and fills
 * pkss__cl_api. The macros at the end redirect the usual cl* names to the
 * table, so device.c and evaluate_cl.c make the same calls as before
 * (results stay bit-identical) and PKSS_CL_CHECK's #call text still reads
 * "clEnqueueNDRangeKernel(...)". Include after <CL/cl.h>, only from the
 * OpenCL modules (pkss_cl.h does).
 */
#ifndef PKSS_CL_LOADER_H
#define PKSS_CL_LOADER_H

#ifndef CL_API_CALL
#define CL_API_CALL
#endif

/* X(return type, name without the cl prefix, parameter list) */
#define PKSS_CL_FUNCTIONS(X)                                                   \
    X(cl_int, GetPlatformIDs, (cl_uint, cl_platform_id *, cl_uint *))          \
    X(cl_int, GetPlatformInfo,                                                 \
      (cl_platform_id, cl_platform_info, size_t, void *, size_t *))            \
    X(cl_int, GetDeviceIDs,                                                    \
      (cl_platform_id, cl_device_type, cl_uint, cl_device_id *, cl_uint *))    \
    X(cl_int, GetDeviceInfo,                                                   \
      (cl_device_id, cl_device_info, size_t, void *, size_t *))                \
    X(cl_context, CreateContext,                                               \
      (const cl_context_properties *, cl_uint, const cl_device_id *,           \
       void(CL_CALLBACK *)(const char *, const void *, size_t, void *),        \
       void *, cl_int *))                                                      \
    X(cl_int, ReleaseContext, (cl_context))                                    \
    X(cl_command_queue, CreateCommandQueue,                                    \
      (cl_context, cl_device_id, cl_command_queue_properties, cl_int *))       \
    X(cl_int, ReleaseCommandQueue, (cl_command_queue))                         \
    X(cl_program, CreateProgramWithSource,                                     \
      (cl_context, cl_uint, const char **, const size_t *, cl_int *))          \
    X(cl_int, BuildProgram,                                                    \
      (cl_program, cl_uint, const cl_device_id *, const char *,                \
       void(CL_CALLBACK *)(cl_program, void *), void *))                       \
    X(cl_int, GetProgramBuildInfo,                                             \
      (cl_program, cl_device_id, cl_program_build_info, size_t, void *,        \
       size_t *))                                                              \
    X(cl_int, ReleaseProgram, (cl_program))                                    \
    X(cl_program, CreateProgramWithBinary,                                     \
      (cl_context, cl_uint, const cl_device_id *, const size_t *,              \
       const unsigned char **, cl_int *, cl_int *))                            \
    X(cl_int, GetProgramInfo,                                                  \
      (cl_program, cl_program_info, size_t, void *, size_t *))                 \
    X(cl_kernel, CreateKernel, (cl_program, const char *, cl_int *))           \
    X(cl_int, ReleaseKernel, (cl_kernel))                                      \
    X(cl_int, GetKernelWorkGroupInfo,                                          \
      (cl_kernel, cl_device_id, cl_kernel_work_group_info, size_t, void *,     \
       size_t *))                                                              \
    X(cl_int, SetKernelArg, (cl_kernel, cl_uint, size_t, const void *))        \
    X(cl_mem, CreateBuffer, (cl_context, cl_mem_flags, size_t, void *,         \
                             cl_int *))                                        \
    X(cl_int, ReleaseMemObject, (cl_mem))                                      \
    X(cl_int, EnqueueWriteBuffer,                                              \
      (cl_command_queue, cl_mem, cl_bool, size_t, size_t, const void *,        \
       cl_uint, const cl_event *, cl_event *))                                 \
    X(cl_int, EnqueueReadBuffer,                                               \
      (cl_command_queue, cl_mem, cl_bool, size_t, size_t, void *, cl_uint,     \
       const cl_event *, cl_event *))                                          \
    X(cl_int, EnqueueNDRangeKernel,                                            \
      (cl_command_queue, cl_kernel, cl_uint, const size_t *, const size_t *,   \
       const size_t *, cl_uint, const cl_event *, cl_event *))                 \
    X(cl_int, Finish, (cl_command_queue))                                      \
    X(cl_int, GetEventProfilingInfo,                                           \
      (cl_event, cl_profiling_info, size_t, void *, size_t *))                 \
    X(cl_int, ReleaseEvent, (cl_event))

typedef struct pkss__cl_api {
#define PKSS_CL_MEMBER(ret, name, args) ret(CL_API_CALL *name) args;
    PKSS_CL_FUNCTIONS(PKSS_CL_MEMBER)
#undef PKSS_CL_MEMBER
} pkss__cl_api;

/* Filled once by pkss__cl_load; read-only afterwards. */
extern pkss__cl_api pkss__cl;

/* Loads the ICD loader on first call (thread-safe, once per process; the
 * library is never unloaded: ICDs keep process-lifetime state). Returns 1
 * when every entry point resolved. Otherwise returns 0, the table stays
 * unusable, and pkss__cl_load_error() says why. */
int pkss__cl_load(void);

/* Why the loader could not be used ("" when it could, or before the first
 * pkss__cl_load): names the library tried, dlerror(), and what to install.
 * Static storage, valid for the life of the process. */
const char *pkss__cl_load_error(void);

#ifndef PKSS_CL_LOADER_IMPL
#define clGetPlatformIDs pkss__cl.GetPlatformIDs
#define clGetPlatformInfo pkss__cl.GetPlatformInfo
#define clGetDeviceIDs pkss__cl.GetDeviceIDs
#define clGetDeviceInfo pkss__cl.GetDeviceInfo
#define clCreateContext pkss__cl.CreateContext
#define clReleaseContext pkss__cl.ReleaseContext
#define clCreateCommandQueue pkss__cl.CreateCommandQueue
#define clReleaseCommandQueue pkss__cl.ReleaseCommandQueue
#define clCreateProgramWithSource pkss__cl.CreateProgramWithSource
#define clBuildProgram pkss__cl.BuildProgram
#define clGetProgramBuildInfo pkss__cl.GetProgramBuildInfo
#define clReleaseProgram pkss__cl.ReleaseProgram
#define clCreateProgramWithBinary pkss__cl.CreateProgramWithBinary
#define clGetProgramInfo pkss__cl.GetProgramInfo
#define clCreateKernel pkss__cl.CreateKernel
#define clReleaseKernel pkss__cl.ReleaseKernel
#define clGetKernelWorkGroupInfo pkss__cl.GetKernelWorkGroupInfo
#define clSetKernelArg pkss__cl.SetKernelArg
#define clCreateBuffer pkss__cl.CreateBuffer
#define clReleaseMemObject pkss__cl.ReleaseMemObject
#define clEnqueueWriteBuffer pkss__cl.EnqueueWriteBuffer
#define clEnqueueReadBuffer pkss__cl.EnqueueReadBuffer
#define clEnqueueNDRangeKernel pkss__cl.EnqueueNDRangeKernel
#define clFinish pkss__cl.Finish
#define clGetEventProfilingInfo pkss__cl.GetEventProfilingInfo
#define clReleaseEvent pkss__cl.ReleaseEvent
#endif

#endif /* PKSS_CL_LOADER_H */
