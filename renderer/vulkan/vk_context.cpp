#include "renderer/vulkan/vk_context.h"

#include <chrono>
#include <cstdio>
#include <cstring>
#include <vector>

#include "base/stopwatch.h"

#if defined(__SANITIZE_ADDRESS__)
#include <dlfcn.h>
#include <link.h>

#include <algorithm>
#include <string>
#endif

namespace rgbdcast::vk {

Error vk_error(VkResult r, const char* call) {
  return make_error(r == VK_ERROR_OUT_OF_HOST_MEMORY || r == VK_ERROR_OUT_OF_DEVICE_MEMORY ? ErrorCode::kInternal
                                                                                           : ErrorCode::kUnavailable,
                    std::string("Vulkan: ") + call + " failed (VkResult " + std::to_string(static_cast<int>(r)) + ")");
}

namespace {

VKAPI_ATTR VkBool32 VKAPI_CALL on_debug_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                VkDebugUtilsMessageTypeFlagsEXT,
                                                const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) {
    static_cast<std::atomic<int>*>(user)->fetch_add(1);
    std::fprintf(stderr, "Vulkan validation error: %s\n", data && data->pMessage ? data->pMessage : "(no message)");
  }
  return VK_FALSE;
}

bool has_layer(const char* name) {
  uint32_t n = 0;
  vkEnumerateInstanceLayerProperties(&n, nullptr);
  std::vector<VkLayerProperties> layers(n);
  vkEnumerateInstanceLayerProperties(&n, layers.data());
  for (const auto& l : layers)
    if (std::strcmp(l.layerName, name) == 0) return true;
  return false;
}

bool has_instance_extension(const char* name) {
  uint32_t n = 0;
  vkEnumerateInstanceExtensionProperties(nullptr, &n, nullptr);
  std::vector<VkExtensionProperties> ext(n);
  vkEnumerateInstanceExtensionProperties(nullptr, &n, ext.data());
  for (const auto& e : ext)
    if (std::strcmp(e.extensionName, name) == 0) return true;
  return false;
}

int device_rank(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return 3;
    default:
      return 4;
  }
}

#if defined(__SANITIZE_ADDRESS__)
// Sanitized builds only (scripts/sanitize.sh, gcc's -fsanitize=address). The Vulkan loader unloads the driver it
// opened (lavapipe) in vkDestroyInstance. What the driver allocates once per process (its state built under
// pthread_once during vkCreateInstance, never freed) is then reported by LeakSanitizer at exit with frames in
// "<unknown module>", which no suppression can name, and the fast unwinder stops inside the driver (no frame
// pointers), so the loader's module is not on the stack either. Keeping the objects that instance creation mapped
// (the driver, its LLVM, a layer) loaded with RTLD_NODELETE gives those frames their module's name, which
// tests/sanitizers/lsan.supp matches. It changes when the driver's code is unmapped, nothing of what it runs; release
// builds do not compile it.
std::vector<std::string> loaded_objects() {
  std::vector<std::string> names;
  dl_iterate_phdr(
      [](dl_phdr_info* info, size_t, void* out) {
        auto* names = static_cast<std::vector<std::string>*>(out);
        if (info->dlpi_name && info->dlpi_name[0]) names->push_back(info->dlpi_name);
        return 0;
      },
      &names);
  std::sort(names.begin(), names.end());
  return names;
}

void keep_loaded_since(const std::vector<std::string>& before) {
  for (const std::string& name : loaded_objects())
    if (!std::binary_search(before.begin(), before.end(), name))
      dlopen(name.c_str(), RTLD_LAZY | RTLD_NOLOAD | RTLD_NODELETE);  // a reference never closed: pinned on purpose
}
#endif

}  // namespace

Result<std::unique_ptr<Context>> Context::create(bool validation) {
  std::unique_ptr<Context> ctx(new Context());
#if defined(__SANITIZE_ADDRESS__)
  const std::vector<std::string> loaded_before = loaded_objects();
#endif
  uint32_t loader_version = 0;
  if (vkEnumerateInstanceVersion(&loader_version) != VK_SUCCESS || loader_version < VK_API_VERSION_1_3)
    return make_error(ErrorCode::kUnavailable, "Vulkan: the loader does not offer Vulkan 1.3");

  std::vector<const char*> layers, extensions;
  const char* kValidation = "VK_LAYER_KHRONOS_validation";
  if (validation) {
    if (!has_layer(kValidation))
      return make_error(
          ErrorCode::kUnavailable,
          "Vulkan: VK_LAYER_KHRONOS_validation is not installed (Debian package vulkan-validationlayers)");
    layers.push_back(kValidation);
  }
  const bool debug_utils = has_instance_extension(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  if (validation && debug_utils) extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);

  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "rgbdcast";
  app.apiVersion = VK_API_VERSION_1_3;
  VkDebugUtilsMessengerCreateInfoEXT dbg{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
  dbg.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT;
  dbg.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                    VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  dbg.pfnUserCallback = on_debug_message;
  dbg.pUserData = ctx->validation_errors_.get();

  VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &app;
  ici.enabledLayerCount = static_cast<uint32_t>(layers.size());
  ici.ppEnabledLayerNames = layers.data();
  ici.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  ici.ppEnabledExtensionNames = extensions.data();
  if (validation && debug_utils) ici.pNext = &dbg;  // also catches errors of instance creation itself
  if (VkResult r = vkCreateInstance(&ici, nullptr, &ctx->instance_); r != VK_SUCCESS)
    return vk_error(r, "vkCreateInstance");
#if defined(__SANITIZE_ADDRESS__)
  keep_loaded_since(loaded_before);
#endif
  if (validation && debug_utils) {
    auto create_messenger = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(ctx->instance_, "vkCreateDebugUtilsMessengerEXT"));
    if (!create_messenger || create_messenger(ctx->instance_, &dbg, nullptr, &ctx->messenger_) != VK_SUCCESS)
      return make_error(ErrorCode::kUnavailable, "Vulkan: cannot create the debug-utils messenger");
  }

  uint32_t count = 0;
  vkEnumeratePhysicalDevices(ctx->instance_, &count, nullptr);
  std::vector<VkPhysicalDevice> devices(count);
  vkEnumeratePhysicalDevices(ctx->instance_, &count, devices.data());
  int best_rank = 99;
  uint32_t best_family = 0;
  for (VkPhysicalDevice pd : devices) {
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(pd, &props);
    if (props.apiVersion < VK_API_VERSION_1_3) continue;
    VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
    VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
    f2.pNext = &f13;
    vkGetPhysicalDeviceFeatures2(pd, &f2);
    if (!f13.dynamicRendering || !f2.features.largePoints) continue;
    uint32_t nq = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &nq, nullptr);
    std::vector<VkQueueFamilyProperties> qf(nq);
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &nq, qf.data());
    for (uint32_t q = 0; q < nq; ++q) {
      if (!(qf[q].queueFlags & VK_QUEUE_GRAPHICS_BIT)) continue;
      if (device_rank(props.deviceType) < best_rank) {
        best_rank = device_rank(props.deviceType);
        best_family = q;
        ctx->physical_ = pd;
        ctx->device_name_ = props.deviceName;
      }
      break;
    }
  }
  if (ctx->physical_ == VK_NULL_HANDLE)
    return make_error(ErrorCode::kUnavailable,
                      count == 0 ? "Vulkan: no physical device found (is mesa-vulkan-drivers installed?)"
                                 : "Vulkan: no device with Vulkan 1.3 dynamic rendering, large points and graphics");
  vkGetPhysicalDeviceMemoryProperties(ctx->physical_, &ctx->memory_);

  float priority = 1.0f;
  VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = best_family;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  f13.dynamicRendering = VK_TRUE;
  VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  f2.pNext = &f13;
  f2.features.largePoints = VK_TRUE;
  VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  dci.pNext = &f2;
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  if (VkResult r = vkCreateDevice(ctx->physical_, &dci, nullptr, &ctx->device_); r != VK_SUCCESS)
    return vk_error(r, "vkCreateDevice");
  vkGetDeviceQueue(ctx->device_, best_family, 0, &ctx->queue_);

  VkCommandPoolCreateInfo cpi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  cpi.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT | VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  cpi.queueFamilyIndex = best_family;
  if (VkResult r = vkCreateCommandPool(ctx->device_, &cpi, nullptr, &ctx->command_pool_); r != VK_SUCCESS)
    return vk_error(r, "vkCreateCommandPool");
  VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  if (VkResult r = vkCreateFence(ctx->device_, &fci, nullptr, &ctx->fence_); r != VK_SUCCESS)
    return vk_error(r, "vkCreateFence");
  return ctx;
}

Context::~Context() {
  if (device_) {
    vkDeviceWaitIdle(device_);
    if (fence_) vkDestroyFence(device_, fence_, nullptr);
    if (command_pool_) vkDestroyCommandPool(device_, command_pool_, nullptr);
    vkDestroyDevice(device_, nullptr);
  }
  if (messenger_) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
    if (destroy) destroy(instance_, messenger_, nullptr);
  }
  if (instance_) vkDestroyInstance(instance_, nullptr);
}

int Context::find_memory_type(uint32_t type_bits, VkMemoryPropertyFlags want) const {
  for (uint32_t i = 0; i < memory_.memoryTypeCount; ++i)
    if ((type_bits & (1u << i)) && (memory_.memoryTypes[i].propertyFlags & want) == want) return static_cast<int>(i);
  return -1;
}

Status Context::begin_one_shot(VkCommandBuffer* cmd) {
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = command_pool_;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  if (VkResult r = vkAllocateCommandBuffers(device_, &ai, cmd); r != VK_SUCCESS)
    return vk_error(r, "vkAllocateCommandBuffers");
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  if (VkResult r = vkBeginCommandBuffer(*cmd, &bi); r != VK_SUCCESS) {
    vkFreeCommandBuffers(device_, command_pool_, 1, cmd);
    return vk_error(r, "vkBeginCommandBuffer");
  }
  return ok_status();
}

Status Context::end_submit_wait(VkCommandBuffer cmd, double* submit_ms) {
  Status status = ok_status();
  if (VkResult r = vkEndCommandBuffer(cmd); r != VK_SUCCESS) {
    status = vk_error(r, "vkEndCommandBuffer");
  } else {
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd;
    const auto t0 = std::chrono::steady_clock::now();
    if (VkResult r = vkQueueSubmit(queue_, 1, &si, fence_); r != VK_SUCCESS) {
      status = vk_error(r, "vkQueueSubmit");
    } else {
      if (VkResult w = vkWaitForFences(device_, 1, &fence_, VK_TRUE, UINT64_MAX); w != VK_SUCCESS)
        status = vk_error(w, "vkWaitForFences");
      vkResetFences(device_, 1, &fence_);
      if (submit_ms) *submit_ms = ms_since(t0);
    }
  }
  vkFreeCommandBuffers(device_, command_pool_, 1, &cmd);
  return status;
}

}  // namespace rgbdcast::vk
