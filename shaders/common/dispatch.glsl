// Linear workgroup / invocation indices for dispatches that the host folded
// into 2-D or 3-D because x would pass maxComputeWorkGroupCount[0]
// (engine/gpu/commands.h). Folded grids overshoot slightly: always bound-check.
#ifndef ICUBE_DISPATCH_GLSL
#define ICUBE_DISPATCH_GLSL

uint icube_group_linear() {
  return gl_WorkGroupID.x + gl_NumWorkGroups.x * (gl_WorkGroupID.y + gl_NumWorkGroups.y * gl_WorkGroupID.z);
}

// For 1-D workgroups (local_size y = z = 1). A macro, not a function: a
// function body here would be compiled before the shader's local_size layout
// and glslang would silently bake gl_WorkGroupSize = (1, 1, 1) into it.
#define ICUBE_THREAD_LINEAR() (icube_group_linear() * gl_WorkGroupSize.x + gl_LocalInvocationID.x)

#endif
