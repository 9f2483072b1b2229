/* SPDX-License-Identifier: Apache-2.0 */
/* The UART driver (rtl/soc/hg_uart.v): status bits, the receive FIFO's head, the transmit
 * holding register. */
#include "uart.h"
#include "soc.h"

static volatile uint32_t *const uart = (volatile uint32_t *)SOC_UART_BASE;

bool uart_rx_ready(void)
{
    return (uart[SOC_UART_STATUS] & SOC_UART_RX_AVAIL) != 0;
}

uint8_t uart_rx(void)
{
    return (uint8_t)uart[SOC_UART_DATA];
}

void uart_send(const uint8_t *d, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        while (!(uart[SOC_UART_STATUS] & SOC_UART_TX_READY))
            ;
        uart[SOC_UART_DATA] = d[i];
    }
}

uint32_t uart_baud(void)
{
    return uart[SOC_UART_BAUD];
}
