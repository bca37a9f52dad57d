#pragma once
// The Vulkan instance, device and queue of the headless backend: no window, no surface, no swapchain. Picks a GPU
// when there is one, else a CPU device (Mesa lavapipe). With validation on, VK_LAYER_KHRONOS_validation is enabled
// and a debug-utils messenger counts (and prints) its errors.
#include <vulkan/vulkan.h>

#include <atomic>
#include <memory>
#include <string>

#include "scene/result.h"

namespace rgbdcast::vk {

// Turns a VkResult into an Error naming the call that failed.
Error vk_error(VkResult r, const char* call);

class Context {
 public:
  // kUnavailable when there is no Vulkan loader/ICD, no device with a graphics queue and Vulkan 1.3 dynamic
  // rendering, or (validation) no validation layer.
  static Result<std::unique_ptr<Context>> create(bool validation);
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  VkDevice device() const { return device_; }
  VkPhysicalDevice physical_device() const { return physical_; }
  VkQueue queue() const { return queue_; }
  VkCommandPool command_pool() const { return command_pool_; }
  const std::string& device_name() const { return device_name_; }
  int validation_errors() const { return validation_errors_->load(); }
  // A memory type with the given bits among type_bits; -1 when none.
  int find_memory_type(uint32_t type_bits, VkMemoryPropertyFlags want) const;
  // Records with record(cmd), submits, waits. Returns the wall time in ms from submit to idle via *submit_ms.
  template <class F>
  Status submit_and_wait(F&& record, double* submit_ms = nullptr);

 private:
  Context() = default;
  Status begin_one_shot(VkCommandBuffer* cmd);
  Status end_submit_wait(VkCommandBuffer cmd, double* submit_ms);

  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  VkCommandPool command_pool_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  VkPhysicalDeviceMemoryProperties memory_{};
  std::string device_name_;
  std::unique_ptr<std::atomic<int>> validation_errors_ = std::make_unique<std::atomic<int>>(0);
};

template <class F>
Status Context::submit_and_wait(F&& record, double* submit_ms) {
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  if (Status s = begin_one_shot(&cmd); !s) return s;
  record(cmd);
  return end_submit_wait(cmd, submit_ms);
}

}  // namespace rgbdcast::vk
